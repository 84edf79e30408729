"""The friction_drift block: run-in and wear with each guide's sliding distance, subset-safe, recovered, saved."""

import dataclasses

import numpy as np
import pytest

from tendon_id import zoo
from tendon_id.datasets import load_recipe
from tendon_id.diagnosis.splits import Split
from tendon_id.errors import ConfigError
from tendon_id.family.inputs import Stacked
from tendon_id.sim import Effects, Sensors, simulate
from tendon_id.sliding import guide_sliding_distance
from tendon_id.zoo.blocks import ContactGate, RoutingWrap, as_block, block_from_dict
from tendon_id.zoo.blocks.base import EFFECT_BLOCKS
from tendon_id.zoo.blocks.drift import FrictionDrift  # importing it registers the block
from tendon_id.zoo.capstan import CapstanModel
from tendon_id.zoo.inputs import TransmissionInputs
from tendon_id.zoo.snake.diagnosis import make_splits
from tendon_id.zoo.snake.refit import refit

NOISE_ONLY = load_recipe("snake12-noise-only")


def drift_recipe(run_in_drop=0.2, run_in_length_m=0.5, wear_rate_per_m=0.05, sensors=None):
    """``snake12-noise-only`` with fresh sessions and only friction drift beyond the base's contact and stick/slip."""
    drift = {"run_in_drop": run_in_drop, "run_in_length_m": run_in_length_m, "wear_rate_per_m": wear_rate_per_m}
    effects = Effects(enabled=("contact", "stick_slip", "friction_drift"), params={"friction_drift": drift})
    return dataclasses.replace(NOISE_ONLY, session="fresh", effects=effects, sensors=sensors or NOISE_ONLY.sensors)


def true_blocks(recipe):
    """The base's blocks at the simulated robot's clearance and routing wrap."""
    gate = recipe.effects.get("contact").gate
    return (
        ContactGate(alpha_c=recipe.robot.alpha_c, gate=gate),
        "hysteresis",
        RoutingWrap(alpha_0=recipe.robot.alpha_0),
    )


def true_law(recipe):
    return np.array([recipe.friction.A]), np.array([recipe.friction.B])


def rmse(model, inputs) -> float:
    e = inputs.terminal - model.terminal_reading(inputs, model.A_, model.B_, model.block_params_)
    return float(np.sqrt(np.mean(e**2)))


def test_block_registers_and_checks_its_settings():
    assert EFFECT_BLOCKS["friction_drift"] is FrictionDrift
    block = as_block("friction_drift")
    assert isinstance(block, FrictionDrift) and block.stage == "exponent" and block.regressor
    assert block.neutral() == {"run_in_drop": 0.0, "wear_rate_per_m": 0.0, "run_in_length_m": 0.5} == block.initial()
    assert block.bounds == {"run_in_drop": (0.0, 0.9), "wear_rate_per_m": (0.0, 2.0), "run_in_length_m": (0.01, 5.0)}
    # The run-in distance's column is a fall over a short distance: alone, with no fall, it changes nothing.
    probes = dict(block.probes())
    short = {"run_in_drop": 0.2, "wear_rate_per_m": 0.0, "run_in_length_m": 0.05}
    assert probes["friction_drift:run_in_length_m"] == short
    assert probes["friction_drift:run_in_drop"]["run_in_length_m"] == 0.5
    assert "run_in_length_m" not in block.settings()  # fitted, not a setting
    # Without a fall the run-in distance is inert: the diagnosis does not read it at a bound as strain.
    assert block.inert({"run_in_drop": 0.0, "run_in_length_m": 5.0}) == ("run_in_length_m",)
    assert block.inert({"run_in_drop": 0.2, "run_in_length_m": 5.0}) == ()
    assert FrictionDrift(run_in_length_m=0.005).run_in_length_m == 0.005  # any start; a fit clips it
    bad_settings = (
        {"run_in_length_m": 0.0},
        {"prior_sliding_m": -1.0},
        {"run_in_drop": 0.95},
        {"wear_rate_per_m": "x"},
    )
    for bad in bad_settings:
        with pytest.raises(ConfigError, match="friction_drift"):
            FrictionDrift(**bad)


def test_neutral_values_are_the_base_bit_for_bit_and_true_values_the_simulator():
    # Noise-free, near-continuous encoders: only the transmission differs from the model.
    recipe = drift_recipe(sensors=Sensors(noise_n=0.0, encoder_bits=24))
    rec = simulate(recipe, "planned-paths", frames=400, seed=5).recording
    inputs = TransmissionInputs.from_recordings(rec)
    base = CapstanModel(blocks=true_blocks(recipe))
    law = true_law(recipe)
    plain = base.terminal_reading(inputs, *law)
    neutral = base.with_blocks(FrictionDrift(run_in_length_m=0.2, prior_sliding_m=1.0))
    np.testing.assert_array_equal(neutral.terminal_reading(inputs, *law), plain)
    np.testing.assert_array_equal(neutral.exponent(inputs, *law), base.exponent(inputs, *law))
    assert "slid" not in inputs.cache  # the neutral block reads no sliding distance
    # At the simulator's settings the block is the simulator's effect (24-bit angles' sliding is the approximation).
    p = recipe.effects.get("friction_drift")
    oracle = base.with_blocks(FrictionDrift(run_in_drop=p.run_in_drop, wear_rate_per_m=p.wear_rate_per_m))
    assert np.max(np.abs(oracle.terminal_reading(inputs, *law) - rec.terminal)) < 2e-4
    assert np.max(np.abs(plain - rec.terminal)) > 0.1  # and the effect is there to be modelled
    # Its signature: one column per parameter (the run-in distance's a fall over a short one), a change of the reading.
    cols = FrictionDrift().signature(base, inputs, *law, base.block_params())
    assert set(cols) == {f"friction_drift:{p}" for p in ("run_in_drop", "wear_rate_per_m", "run_in_length_m")}
    assert all(c.shape == (400, 3) and np.abs(c).max() > 1e-3 for c in cols.values())
    short, long = cols["friction_drift:run_in_length_m"], cols["friction_drift:run_in_drop"]
    assert np.abs(short).max() > 2 * np.abs(long).max()  # 400 frames slide a fraction of 0.5 m, most of 0.05 m


def test_sliding_distance_runs_over_a_session_and_survives_subsetting():
    recs = [
        simulate(NOISE_ONLY, "planned-paths", frames=300, seed=0).recording,
        simulate(NOISE_ONLY, "posterior-6", frames=200, seed=1).recording,
    ]
    whole = TransmissionInputs.from_recordings(recs)
    # Each recording is a session (as the clock and the simulator have it): the distance restarts with each.
    expected = np.concatenate(
        [guide_sliding_distance(r.angles, r.trajectory_starts, whole.geometry, whole.dt) for r in recs]
    )
    np.testing.assert_allclose(whole.slid, expected, rtol=1e-12, atol=1e-15)
    assert whole.slid.shape == (500, 11) and np.all(whole.slid[[0, 300]] == 0)
    assert np.all(np.diff(whole.slid[:300], axis=0) >= 0) and np.all(np.diff(whole.slid[300:], axis=0) >= 0)
    # The diagnosis's cross-validation cuts one session: a held-out group keeps the distance slid before it.
    long = simulate(NOISE_ONLY, "planned-paths", frames=1200, seed=0).recording  # several trajectories
    session = TransmissionInputs.from_recordings(long)
    splits, _ = make_splits([long], None, session.geometry, 3)
    for s in splits:
        first = np.flatnonzero(np.all(session.actuator == s.test.actuator[0], axis=(1, 2)))[0]  # noisy: unique
        np.testing.assert_array_equal(s.test.slid, session.slid[first : first + s.test.n_frames])
    assert any(np.all(s.test.slid[0] > 0) for s in splits)  # recomputed on the part it would restart from 0
    mask = np.zeros(500, dtype=bool)
    mask[315:] = True  # whole trajectories
    part = whole.subset(mask)
    np.testing.assert_array_equal(part.slid, whole.slid[mask])
    np.testing.assert_array_equal(dataclasses.replace(part, angles=part.angles + 0.01).slid, whole.slid[mask])
    np.testing.assert_array_equal(TransmissionInputs.concat([whole.subset(~mask), part]).slid, whole.slid)


def test_recovers_drift_and_lowers_the_held_out_error():
    # Strong drift for a test-sized session: run-in done in the first ~0.1 m, then wear of 1 per metre slid.
    truth = {"run_in_drop": 0.2, "run_in_length_m": 0.05, "wear_rate_per_m": 1.0}
    recipe = drift_recipe(**truth)
    sim = simulate(recipe, "planned-paths", frames=9000, seed=1)
    rec = sim.recording
    ids = rec.trajectories
    held = np.isin(rec.trajectory_ids, ids[2 * len(ids) // 3 :])
    base = zoo.make("capstan-nonsmooth", n_starts=1, maxeval=60).fit(rec.select(ids[: 2 * len(ids) // 3]))
    # One session cut in two, as the diagnosis's splits cut it: the held-out part keeps the distance slid before it.
    whole = TransmissionInputs.from_recordings(rec, base.geometry_)
    split = Split(whole.subset(~held), whole.subset(held), None)
    # The simulator slides the true angles; the block the measured (12-bit) ones, whose steps add a little.
    s = sim.session
    true_slid = guide_sliding_distance(s.theta, s.reset, base.geometry_, rec.dt)[s.logged]
    ratio = split.test.slid[-1] / true_slid[-1]
    assert np.all((ratio > 1.0) & (ratio < 1.04)), ratio  # measured 1.014-1.024
    start = (base.A_, base.B_, base.block_params_)
    block = FrictionDrift()  # the run-in distance fitted from the default, 0.5 m, ten times the truth's
    with_drift = refit(base.with_blocks(block), split.train, *start, max_nfev=30).model
    without = refit(base, split.train, *start, max_nfev=30).model
    # Measured (seed 1): 1.42 N with the block, 2.79 N without; the truth's own law and drift give 1.40 N.
    assert rmse(with_drift, split.test) < 0.6 * rmse(without, split.test)
    fitted = with_drift.block_params_["friction_drift"]
    # Measured over seeds 0-2, from 0.5 m and from the true 0.05 m alike: drop 0.15-0.19, wear
    # 0.65-0.95 per m, run-in 0.024-0.074 m (the three trade off; the measured sliding is 2 % long).
    assert abs(fitted["run_in_drop"] - truth["run_in_drop"]) < 0.06, fitted
    assert abs(fitted["wear_rate_per_m"] - truth["wear_rate_per_m"]) < 0.4, fitted
    assert 0.4 < fitted["run_in_length_m"] / truth["run_in_length_m"] < 2.5, fitted


def test_model_with_the_block_saves_and_loads(tmp_path):
    rec = simulate(drift_recipe(run_in_length_m=0.05, wear_rate_per_m=1.0), "planned-paths", frames=600, seed=2)
    rec = rec.recording
    block = FrictionDrift(run_in_length_m=0.05, prior_sliding_m=0.01)
    assert block_from_dict(block.to_dict()) == block
    model = zoo.make("capstan-contact", blocks=("contact", block), maxeval=30).fit(rec)
    assert set(model.block_values_["friction_drift"]) == {"run_in_drop", "wear_rate_per_m", "run_in_length_m"}
    folder = model.save(tmp_path / "drift")
    back = zoo.load(folder)
    assert back.block_objects == model.block_objects
    loaded = next(b for b in back.block_objects if isinstance(b, FrictionDrift))
    assert (loaded.run_in_length_m, loaded.prior_sliding_m) == (0.05, 0.01)
    assert back.block_params_ == model.block_params_
    np.testing.assert_array_equal(back.predict_terminal(rec), model.predict_terminal(rec))


@pytest.mark.parametrize("folds", [2, 3, 4])
def test_trajectory_splits_are_the_masked_subsets_as_views_of_one_session(folds):
    """make_splits cuts contiguous trajectory groups as parts (views) of the session: the same arrays
    as the subsets by mask, with a copy only for a training set on both sides of its held-out group."""
    recs = [
        simulate(NOISE_ONLY, "planned-paths", frames=900, seed=0).recording,
        simulate(NOISE_ONLY, "posterior-6", frames=400, seed=1).recording,
    ]
    whole = TransmissionInputs.from_recordings(recs)
    splits, how = make_splits(recs, None, whole.geometry, folds)
    assert how == f"{folds}-fold cross-validation by trajectory"
    ids = np.concatenate([np.char.add(f"{k}/", r.trajectory_ids) for k, r in enumerate(recs)])
    _, first = np.unique(ids, return_index=True)
    for k, (group, s) in enumerate(zip(np.array_split(ids[np.sort(first)], folds), splits)):
        assert isinstance(s.train, Stacked) == (0 < k < folds - 1)  # parts on both sides, stacked when read
        held = np.isin(ids, group)  # the former construction, by the trajectories' text
        for side, mask in ((s.test, held), (s.training(), ~held)):
            want = whole.subset(mask)
            for f in TransmissionInputs.frame_fields:
                np.testing.assert_array_equal(getattr(side, f), getattr(want, f), err_msg=f)
        assert np.shares_memory(s.test.actuator, splits[0].test.actuator.base)
    heldout = TransmissionInputs.concat([s.test for s in splits])
    np.testing.assert_array_equal(heldout.actuator, whole.actuator)
    assert heldout.actuator.base is splits[0].test.actuator.base  # the session itself, not a copy
