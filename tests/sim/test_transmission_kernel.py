"""The compiled transmission pass runs the same physics as the composed blocks (issue 19)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.geometry import RobotGeometry
from tendon_id.sim import simulate, transmit
from tendon_id.sim import transmission_kernel as kernel
from tendon_id.sim.effects import Effects
from tendon_id.sim.transmission import COMPILED_EFFECTS, FrictionLaw

pytestmark = pytest.mark.skipif(not kernel.COMPILED, reason="numba is not installed: only the composed route runs")


@pytest.fixture(scope="module")
def session():
    recipe = load_recipe("snake12-paper")
    res = simulate(recipe, "planned-paths", effects="none", frames=1500, seed=4, progress=False)
    return recipe, res.session


def both(theta, actuator, reset, geometry, friction, effects, dt=0.1):
    args = (theta, actuator, reset, geometry, friction, effects, dt)
    return transmit(*args, compiled=True, with_phi=True), transmit(*args, compiled=False, with_phi=True)


def assert_same_physics(a, b, max_sigma_share=2e-3):
    np.testing.assert_array_equal(np.isnan(a.chain), np.isnan(b.chain))
    np.testing.assert_allclose(a.chain, b.chain, rtol=1e-12, atol=1e-10, equal_nan=True)  # [N]; a slack floor cancels
    np.testing.assert_allclose(a.phi, b.phi, rtol=1e-12, atol=1e-15, equal_nan=True)
    np.testing.assert_array_equal(a.wrap, b.wrap)
    # The slip state may differ only where the output sits on an edge to rounding: rarely, and
    # then between stick and one edge, never between the two edges (a hold keeps such a state).
    differ = a.sigma != b.sigma
    assert differ.mean() <= max_sigma_share
    assert not np.any(differ & (a.sigma * b.sigma == -1))


EFFECT_SETS = [
    (),
    *[(e,) for e in COMPILED_EFFECTS if e != "sensor_bias"],
    ("contact", "stick_slip", "viscoelastic", "per_tendon_wrap"),  # the recipe's
    COMPILED_EFFECTS,  # every effect the pass runs
]


@pytest.mark.parametrize("names", EFFECT_SETS, ids=lambda n: "+".join(n) or "none")
def test_compiled_pass_matches_the_composed_blocks(session, names):
    recipe, ses = session
    eff = recipe.effects.with_enabled(names)
    a, b = both(ses.theta, ses.actuator, ses.reset, recipe.robot, recipe.friction, eff, recipe.dt)
    assert_same_physics(a, b)
    if "stick_slip" in names:
        assert {-1, 0, 1} <= set(np.unique(a.sigma))  # the comparison covered stick and both slips


@pytest.mark.parametrize(
    "params",
    [
        {"stick_slip": {"driver": "motion"}},
        {"per_tendon_wrap": {"model": "projected"}},
        {"bending_stiffness": {"dT_b": 400.0}},  # a loss that slackens tendons to the floor
        {"velocity_friction": {"stribeck_drop": 0.3}},
    ],
    ids=lambda p: next(iter(p)),
)
def test_compiled_pass_matches_every_setting(session, params):
    recipe, ses = session
    eff = Effects(enabled=COMPILED_EFFECTS, params={**recipe.effects.to_dict()["params"], **params})
    a, b = both(ses.theta, ses.actuator, ses.reset, recipe.robot, recipe.friction, eff, recipe.dt)
    assert_same_physics(a, b)
    if "bending_stiffness" in params:
        assert np.nanmin(a.chain) == pytest.approx(1e-3)  # the floor was reached and agrees


def test_a_slip_state_that_differs_is_an_output_on_an_edge_to_rounding(session):
    # With the play operator alone the edges are T_in exp(-+phi): a state may differ only there.
    recipe, ses = session
    a, b = both(ses.theta, ses.actuator, ses.reset, recipe.robot, recipe.friction, Effects(enabled=("stick_slip",)))
    ratio = b.chain[:, 1:] / b.chain[:, :-1]
    t, g, j, i = np.nonzero(a.sigma != b.sigma)
    r, p = ratio[t, g, j, i], b.phi[t, g, j, i]
    on_edge = np.minimum(np.abs(np.log(r) + p), np.abs(np.log(r) - p))
    assert np.all(on_edge < 1e-12)


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(2, 5),
    frames=st.integers(1, 25),
    bend_deg=st.floats(0.0, 80.0),
    names=st.sets(st.sampled_from([e for e in COMPILED_EFFECTS if e != "sensor_bias"])),
    seed=st.integers(0, 2**32 - 1),
    driver=st.sampled_from(["tension", "motion", "elastic"]),
)
def test_compiled_pass_matches_on_any_motion(n, frames, bend_deg, names, seed, driver):
    """Random robots, poses up to 80 deg per axis (turns past pi/2: the atan2 branch), any effects and driver."""
    rng = np.random.default_rng(seed)
    geometry = RobotGeometry(n_modules=n, joint_gap=rng.uniform(0.004, 0.02), hole_radius=rng.uniform(0.004, 0.02))
    theta = np.deg2rad(rng.uniform(-bend_deg, bend_deg, size=(frames, n, 2)))
    actuator = rng.uniform(5.0, 400.0, size=(frames, n, 3))
    reset = rng.random(frames) < 0.2
    law = FrictionLaw(A=(0.1, 0.2, 0.05), B=(0.2, 0.25, 0.1))  # B >= |A|: mu >= 0 on every wrap
    effects = Effects(
        enabled=tuple(names), params={"guide_wear": {"guides": {1: 1.7}}, "stick_slip": {"driver": driver}}
    )
    a, b = both(theta, actuator, reset, geometry, law, effects)
    assert_same_physics(a, b, max_sigma_share=1.0 if frames * n < 20 else 0.05)


def test_a_negative_law_is_refused_the_same_way(session):
    recipe, ses = session
    theta = np.full((4, 12, 2), np.deg2rad(85.0))
    actuator = np.full((4, 12, 3), 100.0)
    eff = recipe.effects.with_enabled(["per_tendon_wrap"])
    messages = []
    for compiled in (True, False):
        with pytest.raises(ConfigError, match="negative") as err:
            transmit(theta, actuator, np.zeros(4, bool), recipe.robot, recipe.friction, eff, 0.1, compiled=compiled)
        messages.append(str(err.value))
    assert messages[0] == messages[1]


def test_keep_returns_the_kept_frames_of_the_whole_run(session):
    recipe, ses = session
    keep = np.arange(len(ses.reset)) % 3 != 0
    args = (ses.theta, ses.actuator, ses.reset, recipe.robot, recipe.friction, recipe.effects, recipe.dt)
    whole = transmit(*args)
    part = transmit(*args, keep=keep)
    assert whole.phi is None and part.phi is None
    for name in ("chain", "sigma", "wrap"):
        np.testing.assert_array_equal(getattr(part, name), getattr(whole, name)[keep])
    slow = transmit(*args, keep=keep, compiled=False, with_phi=True)
    assert slow.chain.shape == part.chain.shape and slow.phi.shape == (keep.sum(), 11, 12, 3)


def test_the_smooth_edge_runs_on_the_composed_route(session):
    recipe, ses = session
    eff = Effects(enabled=("stick_slip",), params={"stick_slip": {"edge": "smooth"}})
    args = (ses.theta[:200], ses.actuator[:200], ses.reset[:200], recipe.robot, recipe.friction, eff, recipe.dt)
    with pytest.raises(ConfigError, match="sharp edge"):
        transmit(*args, compiled=True)
    np.testing.assert_array_equal(transmit(*args).chain, transmit(*args, compiled=False).chain)
