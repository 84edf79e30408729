"""Identifiability diagnostics: the pieces against independent derivations, and the study end to end."""

import functools
import json
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from tendon_id import zoo
from tendon_id.calibration.law_layout import LawLayout
from tendon_id.cli import main
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.identifiability import IdentifiabilityProblem, StudySettings, analyse, describe_combination, spectrum
from tendon_id.identifiability.learned import learned_comparison
from tendon_id.identifiability.profile import THRESHOLD_95, profile
from tendon_id.identifiability.sampler import hit_and_run, split_rhat
from tendon_id.identifiability.spectrum import WELL_DETERMINED_SD
from tendon_id.report.identifiability import write_report
from tendon_id.sim import simulate
from tendon_id.zoo.inputs import TransmissionInputs

# The fixtures noise_only and study (SMALL settings) are in conftest.py, shared with test_report.py.


# ---- pieces ---------------------------------------------------------------------------------


def test_joint_exponents_reproduce_the_zoo_models_joint_side_predictions(noise_only):
    view = noise_only.fitting_view()
    for tying in ("tied", "per-guide"):
        model = zoo.make("capstan-contact", tying=tying).fit(view)
        inputs = TransmissionInputs.from_recordings([view], model.geometry_)
        problem = IdentifiabilityProblem.from_model(model, inputs, tying)
        for i in range(3):
            theta = problem.layout.join(model.A_[:, i], model.B_[:, i])
            ours = inputs.actuator[:, :, i] * np.exp(-problem.joint_exponents(theta[None])[0])
            np.testing.assert_allclose(ours, model.predict(view)[:, :, i], rtol=1e-9)


def test_spectrum_finds_the_rank_and_says_which_sum_is_seen():
    # Guides 3-5 always share one wrap: only the sum of their B (with A absent) can be seen.
    rng = np.random.default_rng(0)
    X = rng.normal(size=(500, 5))
    X[:, 3] = X[:, 2]
    X[:, 4] = X[:, 2]
    names = ["B_g1_t2", "B_g2_t2", "B_g3_t2", "B_g4_t2", "B_g5_t2"]
    s = spectrum(X.T @ X, names)
    assert s.rank == 3 and s.null_space.shape == (5, 2)
    assert s.words == [
        "B of guides 3–5 (tendon 2): 2 free directions; the data sees only 1 combination: "
        "only the sum of guides 3–5's B for tendon 2"
    ]
    assert np.isinf(s.sd[2]) and np.isfinite(s.sd[0])
    assert np.isinf(s.condition_number)


def test_combinations_are_said_in_the_papers_words():
    assert describe_combination(np.array([0.7, 0.71]), ["A_t1", "B_t1"]) == "mu(0) = A + B for tendon 1"
    assert describe_combination(np.array([0.0, 1.0, 0.0]), ["A", "B", "C"]) == "B alone"
    text = describe_combination(np.array([1.0, -0.5, 0.0, 0.3]), ["A_g1", "A_g2", "B_g1", "B_g2"])
    assert text == "1.00·A_g1 − 0.50·A_g2 + 0.30·B_g2"


def test_hit_and_run_draws_a_truncated_normal_exactly():
    # 1-D: N(0, 1) truncated to [0.5, 3]; 2-D independent: the second coordinate is uniform on [-1, 1].
    M = np.diag([1.0, 0.0])
    b = np.zeros(2)
    C = np.array([[-1.0, 0], [1, 0], [0, -1], [0, 1]])
    d = np.array([-0.5, 3.0, 1.0, 1.0])
    draws = hit_and_run(M, b, C, d, np.array([1.0, 0.0]), n_chains=200, n_steps=400, thin=4, seed=1)
    ref = stats.truncnorm(0.5, 3.0)
    assert abs(draws[:, 0].mean() - ref.mean()) < 0.02
    assert abs(draws[:, 0].std() - ref.std()) < 0.02
    assert abs(draws[:, 1].std() - 1 / np.sqrt(3)) < 0.02
    assert np.all(draws @ C.T <= d + 1e-12)
    assert np.max(split_rhat(draws, 200)) < 1.05


def test_hit_and_run_is_reproducible():
    M, b = np.eye(2), np.zeros(2)
    C, d = np.vstack([np.eye(2), -np.eye(2)]), np.ones(4)
    a = hit_and_run(M, b, C, d, np.zeros(2), n_chains=8, n_steps=40, thin=2, seed=5)
    assert np.array_equal(a, hit_and_run(M, b, C, d, np.zeros(2), n_chains=8, n_steps=40, thin=2, seed=5))


@settings(max_examples=15, deadline=None)
@given(sd=st.floats(0.002, 0.05), mu0=st.floats(0.2, 0.8))
def test_profile_of_a_gaussian_gives_the_textbook_interval(sd, mu0):
    # One tied group, law (A, B) with a diagonal precision in the (mu0, A - B) directions; far from the edges
    # the profile of mu0 = A + B is the parabola (v - mu0)^2 / sd^2, whose 95 % interval is mu0 +- 1.96 sd.
    layout = LawLayout("affine-cosine", 1)
    u = np.array([1.0, 1.0])  # mu0 direction
    w = np.array([1.0, -1.0])
    M = np.outer(u, u) / sd**2 + np.outer(w, w) / 0.1**2  # u^T M^+ u = sd^2: the sd of mu0 is sd
    theta = np.array([0.1 * mu0, 0.9 * mu0])
    b = M @ theta
    c0 = float(theta @ M @ theta)
    p = profile(M, b, c0, theta, u, layout, "mu0", sd=sd)
    half = np.sqrt(THRESHOLD_95) * sd
    assert p.verdict == "identifiable"
    # The crossing is interpolated linearly between grid points of the parabola: within 2 % of sd.
    assert p.ci[0] == pytest.approx(mu0 - half, abs=0.02 * sd)
    assert p.ci[1] == pytest.approx(mu0 + half, abs=0.02 * sd)


def test_settings_validate_themselves():
    with pytest.raises(ConfigError, match="model"):
        StudySettings(model="capstan-nonsmooth")
    with pytest.raises(ConfigError, match="noise_n"):
        StudySettings(noise_n=-1.0)
    with pytest.raises(ConfigError, match="n_steps"):
        StudySettings(n_steps=10, thin=10)


# ---- the study --------------------------------------------------------------------------------


def test_terminal_only_data_leave_the_per_guide_law_rank_deficient_and_the_tied_law_full_rank(study):
    js = study.to_dict()
    assert js["tied"]["rank"] == js["tied"]["n_params"] == 6
    assert js["tied"]["condition_number"] > 1e3  # sloppy, but full rank
    per = js["per_guide"]
    assert per["n_params"] == 66 and per["rank"] < 66
    assert per["n_unidentifiable"] == 66 - per["rank"]
    assert per["condition_number"] is None
    assert any("free directions" in w for w in per["unidentifiable"])
    assert per["profile_verdicts"].get("structurally unidentifiable", 0) > 0


def test_a_and_b_are_sloppy_while_their_sum_is_tight(study):
    tied = study.studies["tied"]
    post = study.to_dict()["tied"]["posterior"]
    for i in range(3):
        assert tied.correlation(i)[0, 1] < -0.95
        assert post[f"mu0_t{i + 1}"]["sd"] < 0.1 * post[f"A_t{i + 1}"]["sd"]
    assert tied.spectra[0].determined[0].startswith("mu(0) = A + B")


def test_well_determined_lists_only_directions_within_the_threshold_and_the_rest_as_sloppy():
    # A tied law whose mu(0) direction (A + B) has a unit-norm sd a quarter of the threshold and whose
    # A - B direction has four times it: only mu(0) is well determined, A - B is sloppy.
    u, w = np.array([1.0, 1.0]) / np.sqrt(2), np.array([1.0, -1.0]) / np.sqrt(2)
    sd_u, sd_w = WELL_DETERMINED_SD / 4, 4 * WELL_DETERMINED_SD
    s = spectrum(np.outer(u, u) / sd_u**2 + np.outer(w, w) / sd_w**2, ["A_t1", "B_t1"])
    # As written, A + B (coefficients 1, 1) has sd |(1, 1)| sd_u = sqrt(2) sd_u; A - B likewise.
    assert s.determined == [f"mu(0) = A + B for tendon 1 (sd {np.sqrt(2) * sd_u:.3g})"]
    assert s.sloppy == [f"1.00·A_t1 − 1.00·B_t1 (sd {np.sqrt(2) * sd_w:.3g})"]
    assert (s.n_determined, s.n_sloppy) == (1, 1)


def test_the_study_json_keeps_sloppy_directions_out_of_well_determined(study):
    for key in ("tied", "per_guide"):
        js = study.to_dict()[key]
        assert js["n_well_determined"] + js["n_sloppy"] == js["rank"]
        assert not any("sloppiest" in w for w in js["well_determined"])
    for tying in study.studies.values():
        for s in tying.spectra:
            # Each listed direction's eigenvalue is on its side of the threshold.
            ev = s.eigenvalues[: s.rank]
            assert len(s.determined) == min(3, int(np.sum(ev >= 1 / WELL_DETERMINED_SD**2)))
            assert len(s.sloppy) == min(3, int(np.sum(ev < 1 / WELL_DETERMINED_SD**2)))


def test_the_exact_sampler_and_emcee_agree_on_the_tied_posterior(study):
    post = study.to_dict()["tied"]["posterior"]
    em = study.emcee["parameters"]
    for i in range(1, 4):
        assert post[f"A_t{i}"]["sd"] == pytest.approx(em[f"A_{i}"]["sd"], rel=0.35)
        assert post[f"A_t{i}"]["mean"] == pytest.approx(em[f"A_{i}"]["mean"], abs=3 * em[f"A_{i}"]["sd"])


def test_without_unmodelled_effects_the_tied_band_covers_the_truth_and_the_per_guide_band_is_wider(study):
    b = study.to_dict()["bands"]
    assert not study.misspecification["misspecified"]
    assert b["truth_coverage_min_joint"] >= 0.9
    assert b["per_guide_width_mean"] > b["tied_width_mean"]


def test_the_suggested_joint_narrows_the_band_more_than_the_median_alternative(study):
    adv = study.to_dict()["advice"]
    widths = {c["joint"]: c["band_width_mean"] for c in adv["check"]}
    chosen = widths.pop(adv["instrument_joint"])
    assert chosen < np.median(list(widths.values()))
    assert max(adv["candidates"], key=lambda c: c["log_det"])["joint"] == adv["instrument_joint"]
    # The capstan law is the truth here: the check against the truth confirms the linearised advice.
    assert adv["verdict"]["status"] == "confirmed" and adv["verdict"]["recommended_joint"] == adv["instrument_joint"]


def test_the_check_scores_each_candidate_against_the_truth(study, noise_only):
    adv = study.to_dict()["advice"]
    base = study.studies["per-guide"].band
    assert adv["check_baseline"]["band_width_mean"] == base.mean_width()
    truth = noise_only.joint_truth[base.frames]
    rmse0 = np.sqrt(np.mean((base.median[:, 1:-1] - truth[:, 1:-1]) ** 2))
    assert adv["check_baseline"]["rmse_n"] == pytest.approx(rmse0)
    for c in adv["check"]:
        assert c["measured_shrinkage"] == pytest.approx(1 - c["band_width_mean"] / base.mean_width())
        assert 0.0 <= c["truth_coverage"] <= 1.0 and c["rmse_n"] > 0


def test_intermediate_truth_is_never_used_to_fit(noise_only):
    frame = noise_only.frame.copy()
    rng = np.random.default_rng(0)
    terminal = f"tension_joint_{noise_only.n_modules}_"
    for c in [c for c in frame.columns if c.startswith("tension_joint_") and not c.startswith(terminal)]:
        frame[c] = rng.permutation(frame[c].to_numpy())
    scrambled = type(noise_only)(frame, noise_only.meta)
    quick = StudySettings(n_chains=16, n_steps=60, thin=5, band_frames=200, emcee=False, check_advice=False)
    a, b = analyse(noise_only, quick).to_dict(), analyse(scrambled, quick).to_dict()
    for key in ("tied", "per_guide", "advice"):
        assert json.dumps(a[key], default=str) == json.dumps(b[key], default=str)
    assert a["bands"]["tied_width_mean"] == b["bands"]["tied_width_mean"]
    assert a["bands"]["truth_coverage"] != b["bands"]["truth_coverage"]


def test_a_misspecified_model_is_reported_as_such(misspecified):
    js = misspecified.to_dict()
    assert js["misspecification"]["misspecified"]
    assert js["misspecification"]["numbers_describe"] == "the misspecified fit, not the robot"
    assert 0.0 <= js["bands"]["truth_coverage"] <= 1.0


# ---- the command --------------------------------------------------------------------------------


def test_identifiability_command_writes_a_self_contained_report_and_the_design_json(tmp_path, capsys, monkeypatch):
    import tendon_id.identifiability as identifiability

    # The command's wiring and page at the conftest's SMALL sampler sizes (the defaults take a minute).
    small = {"n_chains": 32, "n_steps": 300, "thin": 10, "band_frames": 400}
    # the command imports StudySettings from the package when it runs
    monkeypatch.setattr(identifiability, "StudySettings", functools.partial(StudySettings, **small))
    rec = simulate(load_recipe("snake12-noise-only"), "terminal-only", frames=2000, seed=0).recording
    data = rec.write(tmp_path / "to.parquet")
    out, js = tmp_path / "rep" / "ident.html", tmp_path / "ident.json"
    assert main(["identifiability", "--data", str(data), "--out", str(out), "--json", str(js)]) == 0
    html = out.read_text()
    # No link out of the page: base64 images are left out of the search ("http" can occur in their text).
    body = re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "", html.split("<body>")[1])
    assert html.count('src="data:image/png;base64,') == 7 and "http" not in body
    assert "<title>Identifiability: snake12-noise-only, terminal-only</title>" in html
    doc = json.loads(js.read_text())
    for key in ("n_params", "rank", "condition_number", "unidentifiable"):
        assert key in doc["tied"] and key in doc["per_guide"]
    for key in ("tied_width_mean", "per_guide_width_mean", "truth_coverage"):
        assert isinstance(doc["bands"][key], float)
    assert isinstance(doc["advice"]["instrument_joint"], int) and doc["advice"]["excite_joints"]
    assert "wrote" in capsys.readouterr().out


@pytest.mark.parametrize(
    "args, message",
    [
        (["--data", "missing.parquet", "--out", "r.html"], "missing.parquet"),
        (["--out", "r.html"], "--data"),
        (["--data", "DATA", "--out", "r.pdf"], "HTML"),
        (["--data", "DATA", "--out", "r.html", "--model", "capstan-nonsmooth"], "model"),
    ],
)
def test_identifiability_command_rejects_bad_input_with_exit_2(tmp_path, capsys, args, message):
    rec = simulate(load_recipe("snake12-noise-only"), "terminal-only", frames=200, seed=0).recording
    data = rec.write(tmp_path / "d.parquet")
    args = [str(data) if a == "DATA" else (str(tmp_path / a) if a.endswith((".html", ".pdf")) else a) for a in args]
    assert main(["identifiability", *args]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "r.html").exists()


def test_the_learned_comparison_reports_error_and_seed_spread_for_both_tyings():
    rec = simulate(load_recipe("snake12-noise-only"), "terminal-only", frames=1200, seed=2).recording
    out = learned_comparison([rec.fitting_view()], rec.joint_truth, seeds=2, preset="tiny", progress=False)
    assert set(out) == {"tied", "per_guide"}
    for d in out.values():
        assert d["seeds"] == 2 and len(d["joint_rmse"]) == 2
        assert np.isfinite(d["joint_rmse_mean"]) and d["seed_spread_mean_n"] > 0
        assert len(d["seed_spread_per_joint_n"]) == rec.n_modules
        assert d["seed_spread_per_joint_n"][0] < 1e-9  # joint 1 is the actuator side in every model


def test_data_without_truth_gets_a_report_with_no_coverage_and_no_check(tmp_path, noise_only):
    quick = StudySettings(n_chains=16, n_steps=60, thin=5, band_frames=200, emcee=False)
    result = analyse(noise_only.fitting_view(), quick)
    js = result.to_dict()
    assert js["bands"]["truth_coverage"] is None and js["advice"]["check"] is None
    assert js["advice"]["verdict"]["status"] == "unchecked"
    page = write_report(result, tmp_path / "r.html", tmp_path / "r.json").read_text()
    assert page.count('src="data:image/png;base64,') == 7
    assert "Unchecked linearised advice (no intermediate truth to check it against)" in page
    assert "Instrument joint" not in page and "measured narrowing" not in page
    assert json.loads((tmp_path / "r.json").read_text())["bands"]["truth_coverage"] is None
