"""The candidate blocks: one per simulator effect, each the simulator's physics, with one hook per stage."""

import dataclasses
import inspect

import numpy as np
import pytest

from tendon_id.benchmarks.oracle import oracle_blocks
from tendon_id.benchmarks.withheld import NO_BLOCK_YET
from tendon_id.datasets import load_recipe
from tendon_id.sim import Effects, Sensors, simulate
from tendon_id.sim.effects import EFFECT_NAMES, EFFECT_OPTIONS
from tendon_id.zoo import load
from tendon_id.zoo.blocks import (
    BLOCK_TYPES,
    EFFECT_BLOCKS,
    STAGES,
    Block,
    FrictionDrift,
    GuideWear,
    StartState,
    as_block,
    block_from_dict,
)
from tendon_id.zoo.capstan import CapstanModel
from tendon_id.zoo.inputs import TransmissionInputs

# Noise-free, near-continuous encoders, fresh sessions: only the transmission differs from the model.
RECIPE = dataclasses.replace(
    load_recipe("snake12-paper"), session="fresh", sensors=Sensors(noise_n=0.0, encoder_bits=24)
)
TRUE_LAW = (np.array([RECIPE.friction.A]), np.array([RECIPE.friction.B]))
#: The simulator's effects that a candidate block models.
MODELLED = tuple(e for e in EFFECT_NAMES if e not in NO_BLOCK_YET)


def test_every_simulator_effect_has_its_block():
    # and each option named as an effect, and the start state a continuous session leaves a log in
    assert set(EFFECT_BLOCKS) == set(MODELLED) | set(EFFECT_OPTIONS) | {"start_state"}
    assert NO_BLOCK_YET == ()
    for effect, cls in EFFECT_BLOCKS.items():
        assert cls.effect == effect
        assert as_block(effect).name == cls.name  # the effect's name builds its block


@pytest.mark.parametrize("effect", MODELLED + ("smooth_edge", "elastic_tendon", "all"))
def test_block_at_true_settings_is_the_simulator(effect):
    names = MODELLED if effect == "all" else (effect,)
    effects = RECIPE.effects.with_enabled(names) if effect in EFFECT_NAMES or effect == "all" else None
    if effect in EFFECT_OPTIONS:  # an option of stick_slip: a smooth edge at its default (bench) width, elastic tendons
        _, setting, value = EFFECT_OPTIONS[effect]
        stick_slip = dataclasses.replace(RECIPE.effects.get("stick_slip"), **{setting: value})
        effects = Effects(enabled=("stick_slip",), params={**RECIPE.effects.params, "stick_slip": stick_slip})
    rec = simulate(dataclasses.replace(RECIPE, effects=effects), "planned-paths", frames=400, seed=5).recording
    model = CapstanModel(blocks=oracle_blocks(effects, RECIPE.robot, rec.meta.get("sensor_truth")))
    pred = model.terminal_reading(TransmissionInputs.from_recordings(rec), *TRUE_LAW)
    plain = CapstanModel().terminal_reading(TransmissionInputs.from_recordings(rec), *TRUE_LAW)
    # 24-bit angles are the only approximation (the sliding speed's rate, the segments' path lengths).
    tol = 5e-3 if effect in ("velocity_friction", "elastic_tendon", "all") else 2e-4
    assert np.max(np.abs(pred - rec.terminal)) < tol
    assert np.max(np.abs(plain - rec.terminal)) > 100 * tol  # and the effect is there to be modelled


def test_sensor_drift_restarts_with_every_recording():
    """Each recording is a session: read together, two recordings keep the simulator's drift of each."""
    protocols = ("planned-paths", "posterior-6")
    recs = [simulate(RECIPE, p, frames=300, effects="sensor_bias", seed=5).recording for p in protocols]
    inputs = TransmissionInputs.from_recordings(recs)
    assert inputs.clock[recs[0].n_frames] == 0.0
    model = CapstanModel(blocks=oracle_blocks(RECIPE.effects.with_enabled(("sensor_bias",)), RECIPE.robot))
    pred = model.terminal_reading(inputs, *TRUE_LAW)
    assert np.max(np.abs(pred - np.concatenate([r.terminal for r in recs]))) < 2e-4


def test_hooks_of_one_stage_share_one_signature():
    for stage in STAGES:
        sigs = {
            str(inspect.signature(getattr(cls, stage)))
            for cls in BLOCK_TYPES.values()
            if cls.stage == stage and hasattr(cls, stage)
        }
        assert len(sigs) <= 1, (stage, sigs)
    for cls in BLOCK_TYPES.values():
        assert hasattr(cls, cls.stage), cls  # every block implements its stage's hook
        assert cls.regressor, cls  # and says what its effect leaves in the residual


def test_blocks_register_themselves():
    @dataclasses.dataclass(frozen=True)
    class Probe(Block):
        name = "test_probe_block"
        stage = "sensor"

        def sensor(self, tension, ctx, values):
            return tension

    try:
        assert BLOCK_TYPES["test_probe_block"] is Probe
        assert isinstance(as_block("test_probe_block"), Probe)
    finally:
        BLOCK_TYPES.pop("test_probe_block")


def test_signature_columns_are_the_effect_on_the_reading():
    rec = simulate(RECIPE, "planned-paths", frames=300, seed=1).recording
    base = CapstanModel(blocks=("contact",))
    inputs = TransmissionInputs.from_recordings(rec)
    for effect, cls in EFFECT_BLOCKS.items():
        if effect == "contact":
            continue
        block = GuideWear(guides=(3,)) if cls is GuideWear else cls()
        if cls is FrictionDrift:  # 300 frames slide 1-2 cm: a run-in that short, and a fast wear, show in them
            block = FrictionDrift(run_in_length_m=0.01, probe={"run_in_drop": 0.2, "wear_rate_per_m": 5.0})
        model = base.with_blocks("hysteresis") if cls.requires else base  # a smooth edge refines stick/slip
        if cls is StartState:  # a fresh session starts taut, as the base does: the observer needs an inherited state
            continue
        cols = block.signature(model, inputs, *TRUE_LAW, model.block_params())
        assert cols, effect
        for label, col in cols.items():
            assert col.shape == (300, 3)
            assert np.all(np.isfinite(col)) and np.abs(col).max() > 1e-3, (effect, label)


def test_guide_wear_round_trips_and_localises(tmp_path):
    wear = GuideWear(guides=(3, 7), excess=(0.5, 0.2))
    assert block_from_dict(wear.to_dict()) == wear
    recipe = dataclasses.replace(
        RECIPE,
        sensors=Sensors(noise_n=0.5),
        effects=Effects(enabled=("contact", "guide_wear"), params={"guide_wear": {"guides": {6: 2.0}}}),
    )
    rec = simulate(recipe, "planned-paths", frames=1200, seed=3).recording
    base = CapstanModel(blocks=("contact",)).fit(rec)
    inputs = base.inputs(rec)
    resid = inputs.terminal - base.predict_terminal(rec)
    found = GuideWear.localise(base, inputs, base.A_, base.B_, base.block_params_, resid)
    assert 6 in found.guides
    fitted = base.with_blocks(GuideWear(guides=(6,)), "sensor_bias").fit(rec)
    fitted.save(tmp_path / "m")
    again = load(tmp_path / "m")
    assert again.block_objects == fitted.block_objects
    np.testing.assert_array_equal(again.predict_terminal(rec), fitted.predict_terminal(rec))


@pytest.mark.parametrize(
    "spec, ok",
    [
        ({"block": "routing", "alpha_0": None}, False),  # routing has no robot's value to fall back on
        ({"block": "routing", "alpha_0": "0.1"}, False),
        ({"block": "contact", "alpha_c": None}, True),  # None: the robot's clearance angle
    ],
)
def test_a_block_file_value_is_a_number_or_a_documented_null(spec, ok):
    """Found by the 10 000-example model-file fuzz: a null routing wrap loaded, then failed in predict."""
    from tendon_id.errors import ConfigError
    from tendon_id.zoo.blocks import block_from_dict

    if ok:
        assert block_from_dict(spec).initial()
    else:
        with pytest.raises(ConfigError, match="must be a finite number"):
            block_from_dict(spec)
