"""The bench passage's sensor and elasticity blocks: neutral is the model without them, and refits recover them."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from passage_data import TRUE, tendon_passage

from friction_models import shifted_read
from tendon_id import zoo
from tendon_id.data.passage import PassageRecording
from tendon_id.diagnosis import DiagnosisSettings, diagnose
from tendon_id.errors import ConfigError
from tendon_id.zoo.passage import PassageCapstan, PassageInputs
from tendon_id.zoo.passage.fitting import confounded_groups, data_scales, parameter_box

NEUTRAL = {
    "input_cells": {"input_cells:gain": 0.0, "input_cells:offset": 0.0},
    "clock_skew": {"clock_skew:skew_s": 0.0},
    "cable_elasticity": {"cable_elasticity:compliance": 0.0},
}
SETTINGS = DiagnosisSettings(n_boot=200, block_s=2.0)
TORQUE = {"gain": 0.7, "phi": 0.8, "pretension": 0.05, "sharing": 0.2, "offset": 0.01, "input_offset": 0.005}


def torque_passage(seed: int, n: int = 600) -> PassageRecording:
    """A bench-like antagonistic pair: input torque [N m] and spindle angle [rad], at 1 kHz."""
    t = np.arange(n) * 1e-3
    position = 0.5 * np.sin(2 * np.pi * 2.0 * t + seed)
    frame = {"trajectory": f"pair{seed}", "t": t, "input": 0.06 * position + 0.01, "output": 0.0, "position": position}
    rec = PassageRecording(pd.DataFrame(frame), {"quantity": "torque", "wrap_angle": None})
    truth = PassageCapstan(blocks=("stick_slip",)).reading(PassageInputs.from_recordings(rec), TORQUE)
    return PassageRecording(rec.frame.assign(output=truth), rec.meta)


def sensed(seed: int, n: int = 900, cells=(0.0, 0.0), skew_s=0.0, compliance=0.0, position=True) -> PassageRecording:
    """A tendon passage (:func:`passage_data.tendon_passage`) whose truth has one of the new effects.

    ``cells``: the input sensor reads ``(1 + g) x + o``; ``skew_s``: the output is logged ``skew_s``
    late; ``compliance``: the passage's state is the elastic cable's, not stick/slip.
    """
    rec = tendon_passage(seed, n=n)
    inputs = PassageInputs.from_recordings(rec)
    if compliance > 0:
        model, theta = PassageCapstan(blocks=("cable_elasticity",)), {"cable_elasticity:compliance": compliance}
    else:
        model, theta = PassageCapstan(blocks=("stick_slip",)), {}
    truth = model.reading(inputs, {**TRUE, **theta})
    if skew_s:
        truth = shifted_read(truth, skew_s / inputs.dt, inputs.reset)
    noise = 0.05 * np.random.default_rng(100 + seed).standard_normal(n)
    g, o = cells
    frame = rec.frame.assign(output=truth + noise, input=(1.0 + g) * rec.frame["input"] + o)
    return PassageRecording(frame if position else frame.drop(columns="position"), rec.meta)


def refit(blocks, train, test) -> tuple[PassageCapstan, float]:
    model = PassageCapstan(blocks=blocks, warmup_s=0.5).fit(train)
    return model, model.score(test)["predicted"]["rmse"]


@pytest.mark.parametrize("direction", ["forward", "inverse"])
@pytest.mark.parametrize("base", [(), ("stick_slip",), ("stick_slip", "smooth_edge"), ("position_torque",)])
@pytest.mark.parametrize("effect", list(NEUTRAL))
def test_a_new_block_at_neutral_is_the_base_bit_for_bit(effect, base, direction):
    if effect == "cable_elasticity" and "stick_slip" in base:
        with pytest.raises(ConfigError, match="two states of one passage"):
            PassageCapstan(blocks=(*base, effect)).block_objects  # noqa: B018
        return
    for rec, law in [(tendon_passage(0, n=500), TRUE), (torque_passage(1), TORQUE)]:
        inputs = PassageInputs.from_recordings(rec)
        theta = {**law, "smooth_edge:width": 0.2, "position_torque:k1": 0.01, "position_torque:k2": 0.002}
        plain = PassageCapstan(blocks=base, direction=direction).reading(inputs, theta)
        with_block = PassageCapstan(blocks=(*base, effect), direction=direction)
        assert with_block.reading(inputs, {**theta, **NEUTRAL[effect]}).tobytes() == plain.tobytes()


def test_the_new_blocks_declare_units_bounds_and_probes_inside_them():
    rec = tendon_passage(0, n=500)
    inputs = PassageInputs.from_recordings(rec)
    scale = data_scales(inputs)
    assert scale["dt"] == pytest.approx(0.01)
    for effect in NEUTRAL:
        block = PassageCapstan(blocks=(effect,)).block_objects[0]
        bounds, probe = block.bounds(scale), block.probe(scale)
        assert set(bounds) == set(probe) == set(block.units) == set(block.param_names) == set(block.neutral())
        for p, (lo, hi) in bounds.items():
            assert lo <= block.neutral()[p] <= hi and lo < probe[p] < hi, (effect, p)
    # A skew of five sample periods either side.
    labels, lo, hi = parameter_box(PassageCapstan(blocks=("clock_skew",)), inputs)
    assert hi[labels.index("clock_skew:skew_s")] == pytest.approx(5 * 0.01)


def test_input_cells_recover_the_input_offset_and_the_gain_the_law_can_tell():
    """A tendon's law is linear in its input: the data pin the offset, and the gain only through k / (1 + g)."""
    cells = (0.04, 5.0)  # a 4 % span error and a 5 N zero on an input of 18-42 N
    train, test = [sensed(s, cells=cells) for s in (0, 1)], [sensed(s, cells=cells) for s in (2, 3)]
    _, without = refit(("stick_slip",), train, test)
    model, rmse = refit(("stick_slip", "input_cells"), train, test)
    theta = model.theta_
    # Measured on three other splits (training seeds 0-5): offset 4.70-5.23 N, k / (1 + g) within 0.003.
    assert theta["input_cells:offset"] == pytest.approx(cells[1], abs=0.6)
    assert theta["gain"] / (1 + theta["input_cells:gain"]) == pytest.approx(TRUE["gain"] / (1 + cells[0]), abs=0.01)
    assert rmse < 0.055 and without > 1.1 * rmse  # the noise is 0.05 N; measured 1.18x and more
    groups = confounded_groups(list(theta), model.calibration_["correlation"])
    assert any({"gain", "input_cells:gain"} <= set(g) for g in groups)


def test_clock_skew_recovers_a_fraction_of_a_frame():
    skew = 0.025  # two and a half frames at 100 Hz
    train, test = [sensed(s, skew_s=skew) for s in (0, 1)], [sensed(s, skew_s=skew) for s in (2, 3)]
    _, without = refit(("stick_slip",), train, test)
    model, rmse = refit(("stick_slip", "clock_skew"), train, test)
    # Measured on three other splits (training seeds 0-5): within 0.0004 s of the truth.
    assert model.theta_["clock_skew:skew_s"] == pytest.approx(skew, abs=0.002)
    assert rmse < 0.06 and without > 1.5 * rmse
    # Predicting the input, the same skew reads the prediction earlier; a whole frame is an exact shift.
    inputs = PassageInputs.from_recordings(test)
    for direction, sign in [("forward", 1), ("inverse", -1)]:
        plain = PassageCapstan(blocks=("stick_slip",), direction=direction).reading(inputs, TRUE)
        skewed = PassageCapstan(blocks=("stick_slip", "clock_skew"), direction=direction)
        y = skewed.reading(inputs, {**TRUE, "clock_skew:skew_s": skew})
        np.testing.assert_array_equal(y, shifted_read(plain, sign * skew / inputs.dt, inputs.reset))
    one = skewed.reading(inputs, {**TRUE, "clock_skew:skew_s": 0.01 * (1 + 1e-12)})  # inverse: one frame earlier
    end = np.flatnonzero(inputs.reset)[1]  # the second log's first frame: held there, not read from the first log
    assert np.array_equal(one[1:end], plain[: end - 1]) and one[end] == plain[end]


def test_cable_elasticity_recovers_the_compliance_and_beats_a_force_driven_memory():
    compliance = 0.01  # rad/N: the tendon's band (about 17 N) is crossed over 0.17 rad of travel
    train, test = [sensed(s, compliance=compliance) for s in (0, 1)], [sensed(s, compliance=compliance) for s in (2, 3)]
    _, base = refit((), train, test)
    _, stick = refit(("stick_slip",), train, test)
    model, rmse = refit(("cable_elasticity",), train, test)
    # Measured on three other splits (training seeds 0-5): within 0.1 % of the truth.
    assert model.theta_["cable_elasticity:compliance"] == pytest.approx(compliance, rel=0.02)
    assert rmse < 0.06 < 10 * rmse < min(base, stick)


def test_the_diagnosis_skips_cable_elasticity_without_a_position_column():
    train = [sensed(s, n=600, position=False) for s in (0, 1)]
    test = [sensed(s, n=600, position=False) for s in (2, 3)]
    base, candidates = zoo.make("passage-capstan", warmup_s=0.5), ["stick_slip", "cable_elasticity", "clock_skew"]
    res = diagnose(base, train, test, candidates, settings=SETTINGS, progress=False)
    assert res.skipped["cable_elasticity"] == "needs the position column, which the data lack"
    assert "cable_elasticity" not in {c.effect for c in res.candidates}
    with pytest.raises(ConfigError, match="needs the position column"):
        PassageCapstan(blocks=("cable_elasticity",)).fit(train)


def test_the_diagnosis_names_an_elastic_cable_and_keeps_it_apart_from_stick_slip():
    train = [sensed(s, compliance=0.01) for s in (0, 1)]
    test = [sensed(s, compliance=0.01) for s in (2, 3)]
    res = diagnose(zoo.make("passage-capstan", warmup_s=0.5), train, test, settings=SETTINGS, progress=False)
    assert res.candidates[0].effect == "cable_elasticity" and res.candidates[0].significant
    assert res.candidates[0].params["compliance"] == pytest.approx(0.01, rel=0.02)
    assert res.verdict.kind == "explained" and res.verdict.effects == ["cable_elasticity"]
    # A force-driven memory does worse than none on this passage, and the two never share a model.
    stick = next(c for c in res.candidates if c.effect == "stick_slip")
    assert stick.heldout_rmse > res.base_rmse
    assert all(not {"stick_slip", "cable_elasticity"} <= set(r.effects) for r in res.ladder)


def test_the_diagnosis_names_a_skew_on_top_of_stick_slip():
    train = [sensed(s, skew_s=0.025) for s in (0, 1)]
    test = [sensed(s, skew_s=0.025) for s in (2, 3)]
    base = zoo.make("passage-capstan", warmup_s=0.5, blocks=["stick_slip"])
    res = diagnose(base, train, test, settings=SETTINGS, progress=False)
    top = res.candidates[0]
    assert top.effect == "clock_skew" and top.significant and top.params["skew_s"] == pytest.approx(0.025, abs=0.002)
    assert res.skipped["cable_elasticity"] == "does not compose with the base's blocks"
    assert res.verdict.effects == ["clock_skew"]
