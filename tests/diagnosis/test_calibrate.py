"""The paired test's null: data simulated from the base, the prediction bound, and margins that only rise."""

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from tendon_id import zoo
from tendon_id.datasets import load_recipe
from tendon_id.diagnosis import DiagnosisSettings
from tendon_id.diagnosis import calibrate as cal
from tendon_id.diagnosis.result import Rung
from tendon_id.diagnosis.splits import Split
from tendon_id.diagnosis.stats import NoiseFloor
from tendon_id.diagnosis.verdict import decide, fixed_margins
from tendon_id.errors import ConfigError
from tendon_id.sim import simulate
from tendon_id.zoo.snake.diagnosis import MeasurementNoise, simulate_null


def test_prediction_bound_covers_one_more_draw_at_its_level():
    """Over many samples of 8 normal draws, a ninth exceeds the 95 % bound about 5 % of the time."""
    rng = np.random.default_rng(0)
    x = rng.normal(0.3, 0.05, size=(4000, 9))
    bounds = np.array([cal.prediction_bound(row[:8], 0.95) for row in x])
    assert np.mean(x[:, 8] > bounds) == pytest.approx(0.05, abs=0.012)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-1, 1), min_size=3, max_size=12, unique=True), st.floats(0.6, 0.999))
def test_prediction_bound_is_the_t_formula(xs, level):
    x = np.array(xs)
    n = len(x)
    by_hand = x.mean() + stats.t.ppf(level, n - 1) * x.std(ddof=1) * np.sqrt(1 + 1 / n)
    assert cal.prediction_bound(x, level) == pytest.approx(by_hand)
    assert cal.prediction_bound(x, level) >= x.mean()


def test_simulated_null_is_the_models_reading_of_the_clean_estimates():
    recipe = dataclasses.replace(load_recipe("snake12-paper"), session="fresh")
    rec = [simulate(recipe, "planned-paths", frames=300, seed=3).recording]
    model = zoo.make("capstan-simple").fit(rec)
    inputs = model.inputs(rec)
    split = Split(inputs, inputs)
    law = (model.A_, model.B_, model.block_params_)
    # Sensors without noise or quantum: the labels are the model's reading of what it is fed.
    (quiet,) = simulate_null(MeasurementNoise(1e-9, None), model, split, np.random.default_rng(0))
    for part in (quiet.train, quiet.test):
        assert np.max(np.abs(part.terminal - model.terminal_reading(part, *law))) < 1e-6
        assert part.n_frames == inputs.n_frames
    # With the declared noise the residual of the truth is the cell noise at least.
    noisy = simulate_null(MeasurementNoise(1.0, 2 * np.pi / 2**12), model, split, np.random.default_rng(0), 2)
    e = noisy[0].test.terminal - model.terminal_reading(noisy[0].test, *law)
    assert np.sqrt(np.mean(e**2)) > 0.9
    assert not np.array_equal(noisy[0].test.terminal, noisy[1].test.terminal)  # each draw its own noise
    assert simulate_null(MeasurementNoise(), model, split, np.random.default_rng(0)) is None
    assert simulate_null(None, model, split, np.random.default_rng(0)) is None


def _run(first, end):
    """A ladder whose first rung and end have these held-out mean squared errors (end None: one rung)."""
    ladder = [Rung(["base"], 2.0, 0.0), Rung(["base", "a"], np.sqrt(first), 0.5)]
    if end is not None:
        ladder.append(Rung(["base", "a", "b"], np.sqrt(end), 0.6))
    fits = SimpleNamespace(fits=[None])
    return SimpleNamespace(ladder=ladder, chosen=["a", "b"][: len(ladder) - 1], scores=[fits, fits], score=fits)


@pytest.mark.parametrize("end", [None, 2.0])
@pytest.mark.parametrize("first_bound", [0.05, 0.6])
def test_the_first_rungs_margin_comes_from_its_null_gain(monkeypatch, end, first_bound):
    seen = []

    class FakeDraws:
        def gain(self, effects, structure, fits, level):
            seen.append((effects, level))
            return cal.NullGain(effects, (0.0, 0.1, 0.2), level, first_bound, DiagnosisSettings().null_scale)

    fake = FakeDraws()
    monkeypatch.setattr(cal.NullDraws, "simulate", classmethod(lambda cls, *a, **k: fake))
    run = _run(2.5, end)
    base = SimpleNamespace(with_blocks=lambda *b: "structure")
    s = DiagnosisSettings()
    fits = SimpleNamespace(fits=[None])
    gain, draws = cal.calibrated_margins(None, [None], base, fits, run, {"a": 1, "b": 2}, s, None, n_candidates=13)
    margins = [gain.margin]
    assert seen == [(("a",), pytest.approx(1 - s.alpha / 13))]  # the first rung alone, the best of 13
    assert gain.margin == pytest.approx(np.expm1(s.null_scale * first_bound))
    assert draws is fake  # kept, to measure another structure on the same draws
    # Calibrated, only the first rung is paired: a ladder end that gains more does not show a gap.
    floor = NoiseFloor(2.0, 2.0, "by hand")
    v = decide(3.0, floor, (0.1, 1.0), run.ladder, s, margins=margins)
    assert (v.kind != "none") == (3.0 >= (1 + margins[0]) * 2.5)
    # A calibrated margin below the fixed one shows a gap the fixed one misses, and the reverse.
    assert decide(3.0, floor, (0.1, 1.0), run.ladder[:2], s).kind == "none"  # 3.0 < 1.25 * 2.5
    assert decide(3.0, floor, (0.1, 1.0), run.ladder[:2], s, margins=[0.1]).kind == "explained"
    assert decide(4.0, floor, (0.1, 1.0), run.ladder[:2], s, margins=[0.7]).kind == "none"  # 4.0 < 1.7 * 2.5
    assert fixed_margins(run.ladder, s) == [s.min_excess] * (len(run.ladder) - 1)
    assert fixed_margins(run.ladder[:1], s) == []
    monkeypatch.setattr(cal.NullDraws, "simulate", classmethod(lambda cls, *a, **k: None))  # no sensors declared
    assert cal.calibrated_margins(None, [None], base, fits, run, {"a": 1}, s, None, n_candidates=13) is None


def test_null_draws_share_the_base_and_measure_a_real_gain():
    """On a tiny case, a block that changes nothing gains nothing on the draws; the base's refits are shared."""
    recipe = dataclasses.replace(load_recipe("snake12-paper"), session="fresh")
    train = [simulate(recipe, "planned-paths", frames=300, seed=1).recording]
    test = [simulate(recipe, "planned-paths", frames=300, seed=2).recording]
    base = zoo.make("capstan-simple").fit(train)
    family = base.family
    s = DiagnosisSettings(null_draws=3)
    splits, _ = family.splits(family.recordings(train, "train"), family.recordings(test, "test"), s.folds, base)
    fit = family.refit(base, splits[0].train, family.start(base), s.max_nfev)
    draws = cal.NullDraws.simulate(family, splits, base, [fit], s, np.random.default_rng(0))
    assert len(draws.simulated) == 3 and draws.mse_base.shape == (3,) and np.all(draws.mse_base > 0)
    same = draws.gain(("base",), base, [fit], 0.95)  # the base against itself: no gain on any draw
    assert np.allclose(same.log_ratios, 0.0) and same.margin == pytest.approx(0.0, abs=1e-9)
    again = cal.NullDraws.simulate(family, splits, base, [fit], s, np.random.default_rng(0))
    assert np.array_equal(again.mse_base, draws.mse_base)  # the same seed gives the same draws


def test_null_settings_are_checked():
    assert DiagnosisSettings(null_draws=0).null_draws == 0
    with pytest.raises(ConfigError, match="null_draws"):
        DiagnosisSettings(null_draws=2)
    with pytest.raises(ConfigError, match="null_scale"):
        DiagnosisSettings(null_scale=0.5)


def test_report_says_when_the_paired_test_decided_and_by_what_margin():
    from tendon_id.report.diagnosis import null_gain_lines

    ladder = [Rung(["base"], 1.39, 0.0), Rung(["base", "bending_stiffness"], 1.24, 0.0)]
    gain = cal.NullGain(("bending_stiffness",), (0.2, 0.1, 0.15), 0.996, 0.39, 2.0)
    (line,) = null_gain_lines(SimpleNamespace(base_rmse=1.39, ladder=ladder, null_gains=[gain]))
    assert "3 draws" in line and f"{np.expm1(0.78):.1%}" in line and f"{1.39**2 / 1.24**2 - 1:.1%}" in line
    assert null_gain_lines(SimpleNamespace(base_rmse=1.39, ladder=ladder, null_gains=[])) == []
