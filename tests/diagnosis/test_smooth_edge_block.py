"""The snake's ``smooth_edge`` candidate: it refines stick/slip, fits a simulated edge, the benchmark withholds it."""

import dataclasses

import numpy as np
import pytest

from tendon_id.benchmarks.diagnosis import benchmark_cases
from tendon_id.benchmarks.oracle import oracle_block, oracle_blocks
from tendon_id.benchmarks.withheld import LIBRARY, OUT_OF_LIBRARY, Case, case_recipe
from tendon_id.datasets import load_recipe
from tendon_id.diagnosis import diagnose
from tendon_id.errors import ConfigError
from tendon_id.sim import Effects, Sensors, simulate
from tendon_id.sim.effects import BENCH_EDGE_WIDTH
from tendon_id.zoo.blocks import EFFECT_BLOCKS, ContactGate, RoutingWrap, SmoothEdge, as_block, block_from_dict
from tendon_id.zoo.capstan import CapstanModel
from tendon_id.zoo.inputs import TransmissionInputs
from tendon_id.zoo.snake.refit import refit

RECIPE = load_recipe("snake12-noise-only")


def _recordings(width: float, frames: int, seed: int, noise: float = 0.3) -> list:
    """Contact and a smooth-edged stick/slip; noise-free data come with near-continuous encoders."""
    effects = Effects(enabled=("contact", "stick_slip"), params={"stick_slip": {"edge": "smooth", "edge_width": width}})
    sensors = Sensors(noise_n=noise) if noise > 0 else Sensors(noise_n=0.0, encoder_bits=24)
    recipe = dataclasses.replace(RECIPE, session="fresh", effects=effects, sensors=sensors)
    return [simulate(recipe, p, frames=frames, seed=seed).recording for p in ("posterior-6", "planned-paths")]


def test_block_refines_stick_slip_and_round_trips():
    assert EFFECT_BLOCKS["smooth_edge"] is SmoothEdge and SmoothEdge.requires == ("stick_slip",)
    assert SmoothEdge().probe["width"] == BENCH_EDGE_WIDTH  # the signature's step is the bench's edge
    assert block_from_dict(SmoothEdge(width=0.3).to_dict()) == SmoothEdge(width=0.3)
    with pytest.raises(ConfigError, match="refines stick_slip"):
        CapstanModel(blocks=("contact", "smooth_edge")).block_objects
    with pytest.raises(ConfigError, match="at most one propagation block"):
        CapstanModel(blocks=("hysteresis", "smooth_edge", SmoothEdge(width=0.1, fixed=True))).block_objects
    # In either order the smooth edge sets the step in place of the sharp one, and is the simulator's.
    recs = _recordings(0.4, 200, seed=1, noise=0.0)
    inputs = TransmissionInputs.from_recordings(recs)
    law = (np.array([RECIPE.friction.A]), np.array([RECIPE.friction.B]))
    edge = SmoothEdge(width=0.4)
    # The robot's clearance and routing wrap, as a fit finds them (tests/zoo/test_clearance_fitted.py).
    contact, routing = ContactGate(alpha_c=RECIPE.robot.alpha_c), RoutingWrap(alpha_0=RECIPE.robot.alpha_0)
    a = CapstanModel(blocks=(contact, "hysteresis", edge, routing)).terminal_reading(inputs, *law)
    b = CapstanModel(blocks=(edge, contact, routing, "hysteresis")).terminal_reading(inputs, *law)
    np.testing.assert_array_equal(a, b)
    assert np.max(np.abs(a - inputs.terminal)) < 2e-4  # [N]
    sharp = CapstanModel(blocks=(contact, "hysteresis", routing)).terminal_reading(inputs, *law)
    assert np.max(np.abs(sharp - inputs.terminal)) > 0.1  # and the edge is there to be modelled


def test_oracle_block_is_the_option():
    effects = Effects(enabled=("contact", "stick_slip"), params={"stick_slip": {"edge": "smooth", "edge_width": 0.3}})
    blocks = oracle_blocks(effects, RECIPE.robot)
    assert [b.name for b in blocks] == ["contact", "hysteresis", "smooth_edge", "routing"] and blocks[2].width == 0.3
    assert (blocks[0].alpha_c, blocks[0].gate, blocks[-1].alpha_0) == (RECIPE.robot.alpha_c, "dead_zone", 0.05)
    with pytest.raises(ConfigError, match="option of stick_slip"):
        oracle_block("smooth_edge", Effects(enabled=("contact", "stick_slip")))
    assert as_block("smooth_edge") == SmoothEdge()


@pytest.mark.parametrize("seed", [1, pytest.param(2, marks=pytest.mark.slow)])
def test_refit_from_the_localised_start_recovers_the_width(seed):
    """A doubled bench edge (0.42), 2 x 1200 frames, 0.3 N noise: the diagnosis's refit finds it within 0.15."""
    width = 2 * BENCH_EDGE_WIDTH
    recs = _recordings(width, 1200, seed=seed)
    base = CapstanModel(blocks=("contact", "hysteresis")).fit(recs)
    inputs = base.inputs(recs)
    resid = inputs.terminal - base.predict_terminal(recs)
    start = SmoothEdge.localise(base, inputs, base.A_, base.B_, base.block_params_, resid)
    assert start.width > 0
    structure = base.with_blocks(start)
    fit = refit(structure, inputs, base.A_, base.B_, structure.block_params(base.block_params_))
    assert fit.model.block_values_["smooth_edge"]["width"] == pytest.approx(width, abs=0.15)


def test_base_without_stick_slip_tries_the_smooth_edge_on_the_ladder_only():
    recs = _recordings(0.4, 300, seed=3)
    test = _recordings(0.4, 300, seed=4)
    base = CapstanModel(blocks=("contact",)).fit(recs)
    res = diagnose(base, recs, test, candidates=("stick_slip", "smooth_edge"), progress=False)
    assert res.skipped["smooth_edge"].startswith("refines stick_slip")
    assert [c.effect for c in res.candidates] == ["stick_slip"]
    assert set(res.vote_shares) <= {"stick_slip"}  # the library holds the candidates tried first


def test_benchmark_withholds_the_smooth_edge_in_library():
    assert "smooth_edge" in LIBRARY and "smooth_edge" not in OUT_OF_LIBRARY
    quick = benchmark_cases(quick=True)
    assert Case("single", ("smooth_edge",), "default", 0, 1000) in quick
    full = [c for c in benchmark_cases() if c.truth == ("smooth_edge",)]
    assert {c.magnitude for c in full} == {"half", "default", "double"} and {c.kind for c in full} == {"single"}
    case = Case("single", ("smooth_edge",), "double", 0, 100)
    recipe = case_recipe(case)
    assert case.base == "capstan-nonsmooth"  # a sharp edge: the smooth one is what it lacks
    assert recipe.effects.enabled == ("contact", "stick_slip") and recipe.effects.has("smooth_edge")
    assert recipe.effects.get("stick_slip").edge_width == pytest.approx(2 * BENCH_EDGE_WIDTH)
