"""diagnose(): the result, the verdicts on small withheld-effect problems, and clear errors."""

import dataclasses
import json

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tendon_id import zoo
from tendon_id.datasets import load_recipe
from tendon_id.diagnosis import DiagnosisSettings, diagnose
from tendon_id.diagnosis.stats import block_bootstrap_means, bootstrap_ci
from tendon_id.diagnosis.where import quartile_masks
from tendon_id.errors import ConfigError
from tendon_id.sim import Effects, simulate

# A smooth base (capstan-simple) keeps these tests fast; the physics is snake12-paper's.
RECIPE = dataclasses.replace(load_recipe("snake12-paper"), session="fresh")
CANDIDATES = "sensor_bias,viscoelastic,bending_stiffness"


def _data(effects: tuple[str, ...], seed: int, frames: int):
    recipe = dataclasses.replace(RECIPE, effects=Effects(enabled=effects))
    return [simulate(recipe, "planned-paths", frames=frames, seed=seed).recording]


@pytest.fixture(scope="module")
def withheld_bias():
    train, test = _data(("sensor_bias",), 1, 1200), _data(("sensor_bias",), 2, 600)
    base = zoo.make("capstan-simple").fit(train)
    return diagnose(base, train, test, CANDIDATES)


def test_withheld_sensor_bias_is_named_and_closes_the_gap(withheld_bias):
    r = withheld_bias
    assert r.verdict.kind == "explained" and r.verdict.effects == ["sensor_bias"]
    assert r.candidates[0].effect == "sensor_bias" and r.candidates[0].significant
    assert r.ladder[1].heldout_rmse < r.ladder[0].heldout_rmse and r.ladder[1].gap_closed > 0.8
    assert r.ladder[-1].heldout_rmse < 1.5 * r.noise_floor
    fitted = r.candidates[0].params
    assert fitted["offset"] == pytest.approx(3.0, abs=1.0)  # the simulator's default offset [N]


def test_json_has_the_floor_shape(withheld_bias):
    d = json.loads(json.dumps(withheld_bias.to_dict()))
    assert isinstance(d["base"], str)
    assert set(d["gap"]) >= {"base_rmse", "noise_floor"}
    for row in d["where"]:
        assert set(row) >= {"stratum", "share_error", "share_frames", "bias", "bias_ci"} and len(row["bias_ci"]) == 2
    kinds = {row["kind"] for row in d["where"]}
    assert {"guide", "reversal", "wrap", "speed", "tension", "time"} <= kinds
    for c in d["candidates"]:
        assert set(c) >= {"effect", "heldout_rmse", "gap_closed", "ic_delta", "params"}
    rmse = [c["heldout_rmse"] for c in d["candidates"]]
    assert rmse == sorted(rmse)  # best first
    for rung in d["ladder"]:
        assert isinstance(rung["effects"], list) and rung["heldout_rmse"] > 0
    assert d["verdict"]["kind"] in ("none", "explained", "partial", "unexplained")
    assert set(d["verdict"]) >= {"kind", "effects", "remaining"}


def test_nothing_withheld_gives_no_gap():
    train, test = _data((), 3, 1200), _data((), 4, 600)
    r = diagnose(zoo.make("capstan-simple").fit(train), train, test, CANDIDATES)
    assert r.verdict.kind == "none", r.summary()
    assert r.base_rmse < 1.2 * r.noise_floor


def test_cross_validation_by_trajectory_without_test_data():
    train = _data(("sensor_bias",), 5, 1260)  # 4 trajectories of 315 frames
    r = diagnose(zoo.make("capstan-simple"), train, candidates="sensor_bias", settings=DiagnosisSettings(folds=2))
    assert "cross-validation" in r.validation and r.n_heldout == 1260
    assert r.verdict.effects == ["sensor_bias"]


def test_clear_errors():
    train = _data((), 6, 400)
    with pytest.raises(ConfigError, match="capstan"):
        diagnose(zoo.make("proximal"), train, train)
    with pytest.raises(ConfigError, match="unknown candidate"):
        diagnose(zoo.make("capstan-simple"), train, train, "warp_drive")
    with pytest.raises(ConfigError, match="trajectories"):
        diagnose(zoo.make("capstan-simple"), train, settings=DiagnosisSettings(folds=3))
    with pytest.raises(ConfigError, match="folds"):
        DiagnosisSettings(folds=1)
    with pytest.raises(ConfigError, match="warmup_s"):  # longer than any trajectory: said, not a crash
        diagnose(zoo.make("capstan-simple", warmup_s=100.0).fit(train), train, train, "sensor_bias")


def test_candidates_already_in_the_base_are_skipped():
    train = _data(("contact",), 7, 600)
    r = diagnose(zoo.make("capstan-contact").fit(train), train, train, "contact,sensor_bias")
    assert r.skipped == {"contact": "already in the base"}
    assert [c.effect for c in r.candidates] == ["sensor_bias"]


@given(st.lists(st.floats(-100, 100), min_size=1, max_size=60), st.integers(1, 20), st.integers(0, 10))
def test_block_bootstrap_means_stay_within_the_data(xs, block, seed):
    x = np.array(xs)
    means = block_bootstrap_means(x, block, 64, np.random.default_rng(seed))
    assert np.all(means >= x.min() - 1e-9) and np.all(means <= x.max() + 1e-9)
    lo, hi = bootstrap_ci(x, block, 64, 0.9, np.random.default_rng(seed))
    assert lo <= hi


@given(st.integers(0, 200), st.lists(st.floats(0.01, 10), min_size=2, max_size=200))
def test_quartile_strata_partition_the_frames_and_keep_rest_apart(n_rest, moving):
    speed = np.r_[np.zeros(n_rest), moving]
    strata = quartile_masks(speed, "joint speed", "deg/s", least="joints at rest")
    if np.ptp(speed) == 0:
        assert strata == []
        return
    counts = np.sum([m for _, m in strata], axis=0)
    assert np.all(counts == 1)  # every frame in exactly one stratum
    least = speed == speed.min()
    apart = [m for name, m in strata if "Q" not in name]
    if least.mean() > 0.25:  # a point mass at the least value is its own stratum, not a lumped quartile
        assert len(apart) == 1 and np.array_equal(apart[0], least)
        assert sum(m.any() for _, m in strata) >= 2
    else:
        assert not apart


def test_block_bootstrap_interval_covers_a_known_mean():
    rng = np.random.default_rng(0)
    # AR(1) noise around 2.0: correlated, so a frame-wise bootstrap would be too narrow.
    e = np.zeros(4000)
    for t in range(1, 4000):
        e[t] = 0.9 * e[t - 1] + rng.standard_normal()
    lo, hi = bootstrap_ci(2.0 + e, 50, 500, 0.95, np.random.default_rng(1))
    assert lo < 2.0 < hi


def test_cli_writes_the_report_and_json_and_refuses_bad_input(tmp_path):
    from tendon_id.cli import main

    train, test = _data(("sensor_bias",), 8, 630), _data(("sensor_bias",), 9, 315)
    train[0].write(tmp_path / "train.parquet")
    test[0].write(tmp_path / "test.parquet")
    args = ["diagnose", "--data", str(tmp_path / "train.parquet"), "--test", str(tmp_path / "test.parquet")]
    out, js = tmp_path / "d.html", tmp_path / "d.json"
    rc = main(args + ["--base", "capstan-simple", "--candidates", "sensor_bias", "--out", str(out), "--json", str(js)])
    assert rc == 0
    d = json.loads(js.read_text())
    assert d["base"] == "capstan-simple" and d["candidates"][0]["effect"] == "sensor_bias"
    page = out.read_text()
    assert page.count("data:image/png;base64,") >= 2 and "http" not in page.split("<body>")[1].split("data:")[0]
    for bad in (
        ["--base", "proximal", "--out", str(out)],
        ["--base", "capstan-simple", "--candidates", "nope", "--out", str(out)],
        ["--base", "capstan-simple", "--out", str(tmp_path / "d.txt")],
    ):
        assert main(args + bad) == 2


def test_verdict_rules_by_hand():
    from tendon_id.diagnosis.result import Rung
    from tendon_id.diagnosis.stats import NoiseFloor
    from tendon_id.diagnosis.verdict import decide

    s = DiagnosisSettings()
    base = Rung(["base"], 5.0, 0.0)
    one = Rung(["base", "viscoelastic"], 1.2, 0.95)
    two = Rung(["base", "viscoelastic", "sensor_bias"], 1.1, 0.97)
    floor = NoiseFloor(rmse=1.0, upper=1.0, source="by hand")
    assert decide(1.05, floor, (-0.1, 0.2), [base], s).kind == "none"  # within the floor
    # A significant excess over the expected floor is still none while the sensors alone reach it.
    wide = NoiseFloor(rmse=1.0, upper=1.5, source="by hand")
    assert decide(2.5, wide, (0.5, 2.0), [base], s).kind == "none"
    assert decide(3.0, wide, (1.0, 3.0), [base], s).kind == "unexplained"  # 3.0 > 1.25 * 1.5**2
    # Within what the sensors give, a candidate that lowers the same frames' error by 25 % or more shows a gap.
    paired = Rung(["base", "per_tendon_wrap"], np.sqrt(1.9), 0.3)
    v = decide(2.5, wide, (0.5, 2.0), [base, paired], s)  # 2.5 >= 1.25 * 1.9
    assert (v.kind, v.effects) == ("explained", ["per_tendon_wrap"])
    assert decide(2.5, wide, (0.5, 2.0), [base, Rung(["base", "bending_stiffness"], np.sqrt(2.1), 0.2)], s).kind == (
        "none"
    )  # 2.5 < 1.25 * 2.1
    # A candidate without free parameters cannot absorb the inputs' noise: its significant gain needs no margin.
    small = Rung(["base", "per_tendon_wrap"], np.sqrt(2.3), 0.1)
    assert decide(2.5, wide, (0.5, 2.0), [base, small], s).kind == "none"  # 2.5 < 1.25 * 2.3
    v = decide(2.5, wide, (0.5, 2.0), [base, small], s, structural={"per_tendon_wrap"})
    assert (v.kind, v.effects) == ("explained", ["per_tendon_wrap"])
    margin = DiagnosisSettings(min_excess_structural=0.1)
    assert decide(2.5, wide, (0.5, 2.0), [base, small], margin, structural={"per_tendon_wrap"}).kind == "none"
    # The ladder's end counts too: each rung is significant, and together they clear the margin.
    wear = Rung(["base", "guide_wear"], np.sqrt(2.2), 0.2)
    both = Rung(["base", "guide_wear", "bending_stiffness"], np.sqrt(1.9), 0.4)
    assert decide(2.5, wide, (0.5, 2.0), [base, wear], s).kind == "none"  # 2.5 < 1.25 * 2.2
    v = decide(2.5, wide, (0.5, 2.0), [base, wear, both], s)  # 2.5 >= 1.25 * 1.9
    assert (v.kind, v.effects) == ("explained", ["guide_wear", "bending_stiffness"])
    # A ladder that leaves only what the sensors give explains the gap, whatever share it closed.
    near = Rung(["base", "guide_wear"], 1.6, 0.4)
    v = decide(25.0, wide, (20.0, 30.0), [base, near], s)
    assert (v.kind, v.effects) == ("explained", ["guide_wear"])
    assert decide(25.0, floor, (20.0, 30.0), [base, near], s).kind == "unexplained"  # 1.6**2 > 1.25 * 1.0**2
    assert decide(25.0, floor, (20.0, 30.0), [base], s).kind == "unexplained"
    v = decide(25.0, floor, (20.0, 30.0), [base, one, two], s)
    assert (v.kind, v.effects) == ("explained", ["viscoelastic", "sensor_bias"])
    half = Rung(["base", "bending_stiffness"], 3.0, 0.6)
    assert decide(25.0, floor, (20.0, 30.0), [base, half], s).kind == "partial"
    low = Rung(["base", "bending_stiffness"], 4.5, 0.3)
    assert decide(25.0, floor, (20.0, 30.0), [base, low], s).kind == "unexplained"
    # A strained first rung that closes most of the gap is named as a family in another form; one that
    # closes less is not named; a strained later rung is cut off.
    v = decide(25.0, floor, (20.0, 30.0), [base, one, two], s, {"viscoelastic"})
    assert (v.kind, v.effects, v.label) == ("family", ["viscoelastic"], "viscoelastic")
    assert "another form" in v.text and "95%" in v.text
    assert decide(25.0, floor, (20.0, 30.0), [base, low], s, {"bending_stiffness"}).kind == "unexplained"
    v = decide(25.0, floor, (20.0, 30.0), [base, one, two], s, {"sensor_bias"})
    assert v.effects == ["viscoelastic"]


def test_noise_floor_of_a_ratio_model_is_the_propagated_noise():
    """A smooth capstan passes actuator noise through its ratio: floor^2 = sigma^2 (1 + mean ratio^2)."""
    from tendon_id.zoo.snake.diagnosis import MeasurementNoise, noise_floor

    rec = _data((), 5, 600)
    model = zoo.make("capstan-simple").fit(rec)
    inputs = model.inputs(rec)
    sigma = 2.0
    floor = noise_floor(
        MeasurementNoise(sigma, None), model, inputs, np.zeros((inputs.n_frames, 3)), np.random.default_rng(0)
    )
    ratio = (
        model.terminal_reading(inputs, model.A_, model.B_, model.block_params_) / inputs.actuator[:, -1]
    )  # set N drives the terminal
    expected = sigma * np.sqrt(1.0 + np.mean(ratio**2))
    assert floor.rmse == pytest.approx(expected, rel=0.03)
    assert floor.rmse <= floor.upper < 1.1 * floor.rmse  # a ratio does not ratchet: little spread
    quantised = noise_floor(MeasurementNoise(sigma, 2 * np.pi / 2**12), model, inputs, None, np.random.default_rng(0))
    assert quantised.rmse >= 0.99 * floor.rmse and "encoder" in quantised.source
    diff = noise_floor(MeasurementNoise(), model, inputs, np.random.default_rng(1).normal(0, 1.5, (600, 3)), None)
    assert diff.rmse == pytest.approx(1.5, rel=0.1) and diff.upper == diff.rmse


def test_a_rival_that_closes_nearly_as_much_is_reported():
    from tendon_id.diagnosis.result import CandidateResult, Verdict
    from tendon_id.diagnosis.verdict import with_rivals

    def cand(effect, closed, significant=True):
        return CandidateResult(effect, {}, 1.0, closed, (0.1, 0.2), significant, 0.0, {})

    s = DiagnosisSettings()
    v = Verdict("explained", ["actuator_cells"], 0.0, "explained by actuator_cells")
    ranked = [cand("actuator_cells", 1.01), cand("sensor_bias", 0.95), cand("viscoelastic", 0.2)]
    out = with_rivals(v, ranked, s)
    assert out.rivals == ["sensor_bias"] and out.label == "actuator_cells"
    assert "sensor_bias (95%)" in out.text and "hardly tell them apart" in out.text
    # Not a rival: closing 0.11 less, or not significant, or the verdict names nothing.
    assert with_rivals(v, [cand("actuator_cells", 1.0), cand("sensor_bias", 0.89)], s).rivals == []
    assert with_rivals(v, [cand("actuator_cells", 1.0), cand("sensor_bias", 0.99, False)], s).rivals == []
    none = Verdict("none", [], 0.0, "no significant gap")
    assert with_rivals(none, ranked, s) is none


def test_the_simplest_of_near_equal_candidates_leads_the_ladder():
    from tendon_id.diagnosis.result import CandidateResult, Verdict
    from tendon_id.diagnosis.verdict import parsimonious_lead, with_rivals

    def cand(effect, closed, n_params, significant=True):
        params = {f"p{k}": 0.0 for k in range(n_params)}
        return CandidateResult(effect, {}, 2.0 - closed, closed, (0.1, 0.2), significant, 0.0, params)

    s = DiagnosisSettings()
    cells, bias, visco = cand("actuator_cells", 1.03, 6), cand("sensor_bias", 0.97, 3), cand("viscoelastic", 0.2, 2)
    lead = parsimonious_lead([cells, bias, visco], s)
    assert [c.effect for c in lead] == ["sensor_bias", "actuator_cells", "viscoelastic"]
    out = with_rivals(Verdict("explained", ["sensor_bias"], 0.0, "explained by sensor_bias"), lead, s)
    assert out.rivals == ["actuator_cells"]
    assert "or more" in out.text and "fewer free parameters (3) than actuator_cells (6)" in out.text
    # The best stays first: a simpler candidate 0.11 behind is no rival, nor is an insignificant one,
    # and among rivals with as many parameters the better leads.
    far = cand("sensor_bias", 0.92, 3)
    assert parsimonious_lead([cells, far], s)[0] is cells
    assert parsimonious_lead([cells, cand("sensor_bias", 1.0, 3, False)], s)[0] is cells
    assert parsimonious_lead([cells, cand("clock_skew", 1.0, 6)], s)[0] is cells
    assert parsimonious_lead([cand("x", 0.9, 1, False), bias], s)[0].effect == "x"  # nothing significant leads
    # A rival at the edge of its range does not lead an unstrained best.
    strained = dataclasses.replace(bias, at_bound=("offset",))
    assert parsimonious_lead([cells, strained], s)[0] is cells


def test_what_the_ladder_leaves_may_be_within_its_own_models_floor():
    from tendon_id.diagnosis.result import Rung
    from tendon_id.diagnosis.stats import NoiseFloor
    from tendon_id.diagnosis.verdict import decide

    s = DiagnosisSettings()
    floor = NoiseFloor(rmse=1.4, upper=1.45, source="by hand")
    base, lag = Rung(["base"], 2.1, 0.0), Rung(["base", "load_cell_dynamics"], 1.83, 0.43)
    mse0 = 2.1**2
    assert decide(mse0, floor, (1.0, 3.0), [base, lag], s).kind == "unexplained"  # closes 43 % of the base's gap
    # The lag undone amplifies the cells' noise: at the truth the model errs by 2.1 N, and 1.83 N is within it.
    amplified = NoiseFloor(rmse=2.07, upper=2.13, source="by hand")
    v = decide(mse0, floor, (1.0, 3.0), [base, lag], s, end_floor=amplified)
    assert (v.kind, v.effects) == ("explained", ["load_cell_dynamics"])
    assert "to the ladder's model (its noise floor 2.07 N" in v.text
    # A floor no higher than the base's upper figure changes nothing, nor does one the ladder's end is beyond.
    assert decide(mse0, floor, (1.0, 3.0), [base, lag], s, end_floor=NoiseFloor(1.3, 1.4, "by hand")).kind == (
        "unexplained"
    )
    assert decide(mse0, floor, (1.0, 3.0), [base, lag], s, end_floor=NoiseFloor(1.44, 2.2, "by hand")).kind == (
        "unexplained"
    )  # its upper figure is above, by chance, but its expected floor is not
    assert decide(mse0, floor, (1.0, 3.0), [base, lag], s, end_floor=NoiseFloor(1.5, 1.6, "by hand")).kind == (
        "unexplained"
    )  # 1.83**2 > 1.25 * 1.6**2
