"""What a block declares about its parameters' reach, which the refit's Jacobian relies on, holds for every block.

The refit (:mod:`tendon_id.zoo.snake.refit`) perturbs the three tendons' own parameters in one
evaluation (``Block.param_tendon``) and keeps the chain while it steps a parameter of a block that
acts on the terminal reading alone (``CapstanModel.sensor_only``).  A block that declared either
wrongly would give a wrong Jacobian; each is checked here by stepping the parameter to its probe.
"""

import dataclasses

import numpy as np
import pytest

from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.sim import simulate
from tendon_id.zoo.blocks import BLOCK_TYPES, ContactGate, Hysteresis, RoutingWrap
from tendon_id.zoo.capstan import CapstanModel
from tendon_id.zoo.inputs import TransmissionInputs

RECIPE = load_recipe("snake12-noise-only")
LAW = (np.array([RECIPE.friction.A]), np.array([RECIPE.friction.B]))
BASE = (ContactGate(alpha_c=RECIPE.robot.alpha_c), Hysteresis(), RoutingWrap(alpha_0=RECIPE.robot.alpha_0))
IN_BASE = {b.name for b in BASE}


@pytest.fixture(scope="module")
def inputs():
    recipe = dataclasses.replace(RECIPE, session="fresh")
    rec = simulate(recipe, "planned-paths", effects="contact,stick_slip", frames=300, seed=3).recording
    return TransmissionInputs.from_recordings(rec)


def _models():
    for name, cls in sorted(BLOCK_TYPES.items()):
        if name in IN_BASE:
            continue
        block = cls()
        try:
            model = CapstanModel(blocks=BASE + (block,))
            model.block_objects  # noqa: B018 - composing checks the blocks
        except ConfigError:
            continue  # it does not compose with this base (a per-guide block beside a whole-chain one)
        for label, probe in block.probes():
            if probe:
                yield pytest.param(model, block, probe, id=label)


@pytest.mark.parametrize(("model", "block", "probe"), list(_models()))
def test_a_parameter_moves_only_what_its_block_declares(inputs, model, block, probe):
    values = model.block_params()
    stepped = {**values, block.name: {**values[block.name], **probe}}  # one signature column's step
    before, after = model.terminal_reading(inputs, *LAW, values), model.terminal_reading(inputs, *LAW, stepped)
    moved = np.abs(after - before).max(axis=0) > 0  # per tendon
    assert moved.any(), f"{block.name} at {probe} moves no reading: the check would prove nothing"
    reach = {block.param_tendon(p) for p, v in probe.items() if v != values[block.name][p]}
    if len(reach) == 1 and None not in reach:
        (i,) = reach
        assert moved.tolist() == [k == i for k in range(3)]
    chain_before = model.terminal_tension(inputs, *LAW, values)
    chain_after = model.terminal_tension(inputs, *LAW, stepped)
    if model.sensor_only(block.name):
        np.testing.assert_array_equal(chain_after, chain_before)
    else:
        assert not np.array_equal(chain_after, chain_before)
