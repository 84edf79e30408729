"""The closed loop with any number of tendons per set, and a planar robot (issue 41)."""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tendon_id.closed_loop import (
    STEP_TESTS,
    HybridGains,
    JointDynamics,
    OracleInLoop,
    Plant,
    TensionDistribution,
    loop_metrics,
    run_step_test,
    step_test,
    tension_distribution,
)
from tendon_id.closed_loop.statics import crossing_jacobian, on_path, tendon_moments
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.geometry import tendon_azimuths
from tendon_id.robot_file import load_robot
from tendon_id.sim import FrictionLaw
from tendon_id.sim.body import Body

#: One (A, B) per tendon, as in the brief's example recipes.
FRICTION = {
    4: FrictionLaw(A=(0.3, 0.32, 0.28, 0.3), B=(0.09, 0.08, 0.1, 0.09)),
    2: FrictionLaw(A=(0.3, 0.32), B=(0.09, 0.08)),
}


def _recipe(robot: str):
    """snake12-paper's physics (friction law, effects, actuation, sensors) on another bundled robot."""
    geometry = load_robot(robot)
    return replace(load_recipe("snake12-paper"), name=robot, robot=geometry, friction=FRICTION[geometry.n_tendons])


# --- The tension distribution -------------------------------------------------------------------------


def _old_rule(torque, psi, r, pretension):
    """The three-tendon rule as the controller computed it before issue 41, operation for operation."""
    d = (2.0 / (3.0 * r)) * (torque[..., :1] * np.cos(psi) + torque[..., 1:] * np.sin(psi))
    return pretension + d - d.min(axis=-1, keepdims=True)


def test_three_tendons_at_the_paper_azimuths_give_the_old_rule_to_the_bit():
    psi = tendon_azimuths(load_robot("snake12-paper"))
    torque = np.random.default_rng(0).normal(0.0, 2.0, (50, 12, 2))
    rule = TensionDistribution(psi, 0.012, 80.0)
    assert rule.closed_form
    np.testing.assert_array_equal(rule(torque), _old_rule(torque, psi, 0.012, 80.0))
    for k in range(12):  # one set at a time, as the controller's recursion calls it
        np.testing.assert_array_equal(
            rule(torque[:, k : k + 1], slice(k, k + 1)), _old_rule(torque[:, k : k + 1], psi[k : k + 1], 0.012, 80.0)
        )


@st.composite
def _sets(draw):
    """A set that can pull every way: n azimuths with every gap below 180 deg (or a pair either side of a hinge)."""
    axes = draw(st.sampled_from([1, 2]))
    n = draw(st.integers(2, 6)) if axes == 1 else draw(st.integers(3, 6))
    if axes == 1:
        psi = np.array(draw(st.lists(st.floats(0.0, 2 * np.pi), min_size=n, max_size=n, unique=True)))
        psi[0], psi[1] = draw(st.floats(-1.2, 1.2)), np.pi + draw(st.floats(-1.2, 1.2))  # one each side
    else:
        gaps = np.array(draw(st.lists(st.floats(0.3, 1.0), min_size=n, max_size=n)))
        psi = draw(st.floats(0.0, 2 * np.pi)) + np.cumsum(2 * np.pi * gaps / gaps.sum())
        if np.max(2 * np.pi * gaps / gaps.sum()) >= np.pi - 1e-6:
            psi = np.arange(n) * 2 * np.pi / n
    torque = np.array([draw(st.floats(-3.0, 3.0)), draw(st.floats(-3.0, 3.0))])
    return psi, axes, torque


@settings(max_examples=200, deadline=None)
@given(_sets(), st.floats(10.0, 150.0))
def test_the_distribution_is_the_minimum_norm_tension_above_the_floor(case, pretension):
    """Exerts the moment, no tendon below the floor, and satisfies the optimality (KKT) conditions of
    ``min |t|^2 s.t. A t = b, t >= 0`` (sufficient for a convex programme): some ``lambda`` gives
    ``t_i = lambda . a_i`` where ``t_i > 0`` and ``lambda . a_i <= 0`` where ``t_i = 0``."""
    psi, axes, torque = case
    r = 0.01
    tensions = tension_distribution(torque[None], psi[None], r, pretension, axes)[0]
    A = r * np.stack([np.cos(psi), np.sin(psi)])[:axes]
    np.testing.assert_allclose(A @ tensions, torque[:axes], atol=1e-9)
    assert tensions.min() >= pretension - 1e-9
    t = tensions - pretension
    on = t > 1e-7 * (1.0 + t.max())
    lam = np.linalg.lstsq(A[:, on].T, t[on], rcond=None)[0] if on.any() else np.zeros(axes)
    np.testing.assert_allclose(A[:, on].T @ lam, t[on], atol=1e-6)
    assert np.all(A[:, ~on].T @ lam <= 1e-6)


def test_four_tendons_pull_as_two_puller_follower_pairs():
    """At 0, 90, 180 and 270 deg the programme splits into two pairs: in each, the tendon on the side of the
    moment pulls ``|M_axis| / r`` above the floor and the other stays at it (by hand: ``r (T_1 - T_3) = M_x``,
    ``r (T_2 - T_4) = M_y``, least-squares tensions with the slacker of each pair at the floor)."""
    psi = np.deg2rad([[0.0, 90.0, 180.0, 270.0]])
    r, p = 0.008, 80.0
    for mx, my in ((0.4, 0.0), (0.4, -0.24), (-0.1, 0.3), (0.0, 0.0)):
        got = tension_distribution(np.array([[mx, my]]), psi, r, p)[0]
        hand = [p + max(mx, 0) / r, p + max(my, 0) / r, p + max(-mx, 0) / r, p + max(-my, 0) / r]
        np.testing.assert_allclose(got, hand, rtol=1e-12)


def test_a_hinges_pair_exerts_its_moment_and_ignores_the_other_axis():
    psi = np.deg2rad([[0.0, 180.0]])
    for m in (0.5, -0.5):
        got = tension_distribution(np.array([[m, 7.0]]), psi, 0.01, 80.0, bending_axes=1)[0]
        np.testing.assert_allclose(got, [80.0 + max(m, 0) / 0.01, 80.0 + max(-m, 0) / 0.01], rtol=1e-12)


def test_a_set_that_cannot_pull_every_way_is_refused():
    with pytest.raises(ConfigError, match="one side"):
        TensionDistribution(np.deg2rad([[0.0, 90.0, 170.0]]), 0.01, 80.0)  # nothing pulls towards -y
    with pytest.raises(ConfigError, match="one side"):
        TensionDistribution(np.deg2rad([[30.0, -30.0]]), 0.01, 80.0, bending_axes=1)


# --- The statics, by hand -------------------------------------------------------------------------------


def _chord_moment(tension, ux, h, a):
    """Moment about a hinge bent by ``a`` of a tendon in the bending plane, ``ux`` off the axis, holes ``h``
    either side of the pivot.  Both holes lie ``rho = sqrt(ux^2 + h^2)`` from the pivot, so the tendon is
    the chord ``l = 2 rho cos(beta + a / 2)``, ``beta = atan2(ux, h)`` the holes' angle from the axis (the
    upper hole turns by ``a`` with the link); virtual work: ``tau = -T dl/da = T rho sin(beta + a / 2)``."""
    return tension * np.hypot(ux, h) * np.sin(np.arctan2(ux, h) + 0.5 * a)


@settings(max_examples=30, deadline=None)
@given(st.floats(-0.6, 0.6), st.lists(st.floats(20.0, 300.0), min_size=4, max_size=4))
def test_a_four_tendon_sets_moment_by_hand(a, tension):
    """snake6-quad, joint 1 bent by ``a`` towards x, only set 1 (holes at 0, 90, 180, 270 deg) tensioned.
    Tendons 1 and 3 lie in the bending plane: chords (:func:`_chord_moment`).  Tendons 2 and 4 sit at
    ``(0, +-r)``: about y they are chords of radius ``h`` (``T h sin(a/2)`` each); about x, differentiating
    the segment ``(h sin a, 0, h (1 + cos a))`` under the joint's second rotation, ``dl/db = -u_y cos(a/2)``,
    so ``tau_y = r cos(a/2) (T_2 - T_4)``.  Straight, ``tau = r (T_1 - T_3, T_2 - T_4)``."""
    geometry = load_robot("snake6-quad")
    r, h = geometry.hole_radius, 0.5 * geometry.joint_gap
    np.testing.assert_allclose(tendon_azimuths(geometry)[0], np.deg2rad([0.0, 90.0, 180.0, 270.0]), atol=1e-15)
    theta = np.zeros((6, 2))
    theta[0, 0] = a
    chain = np.zeros((6, 6, 4))
    chain[0, 0] = tension
    ours = tendon_moments(chain, crossing_jacobian(theta, geometry))[0]
    t1, t2, t3, t4 = tension
    hand_x = _chord_moment(t1, r, h, a) + _chord_moment(t3, -r, h, a) + (t2 + t4) * h * np.sin(0.5 * a)
    hand_y = r * np.cos(0.5 * a) * (t2 - t4)
    np.testing.assert_allclose(ours, [hand_x, hand_y], rtol=0, atol=1e-10)
    straight = tendon_moments(chain, crossing_jacobian(np.zeros((6, 2)), geometry))[0]
    np.testing.assert_allclose(straight, [r * (t1 - t3), r * (t2 - t4)], rtol=0, atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(st.floats(-0.6, 0.6), st.integers(0, 2**32 - 1))
def test_a_hinges_pair_moment_by_hand(a, seed):
    """planar6-pair, joint 2 bent by ``a``: sets 2-6 cross it, each pair at 0 and 180 deg.  About y the pair
    gives ``sum_j [chord(T_j1, +r) + chord(T_j2, -r)]``, ``r sum_j (T_j1 - T_j2)`` straight (the guide's sign:
    the tendon at +x bends the joint towards +x); nothing about x (both holes on the x axis)."""
    geometry = load_robot("planar6-pair")
    r, h = geometry.hole_radius, 0.5 * geometry.joint_gap
    chain = np.random.default_rng(seed).uniform(20.0, 300.0, (6, 6, 2)) * on_path(6)[:, :, None]
    theta = np.zeros((6, 2))
    theta[1, 0] = a
    ours = tendon_moments(chain, crossing_jacobian(theta, geometry))[1]
    hand = sum(_chord_moment(chain[1, j, 0], r, h, a) + _chord_moment(chain[1, j, 1], -r, h, a) for j in range(1, 6))
    np.testing.assert_allclose(ours, [hand, 0.0], rtol=0, atol=1e-10)
    straight = tendon_moments(chain, crossing_jacobian(np.zeros((6, 2)), geometry))[1]
    np.testing.assert_allclose(straight, [r * np.sum(chain[1, 1:, 0] - chain[1, 1:, 1]), 0.0], rtol=0, atol=1e-12)


# --- The plant and the loop ---------------------------------------------------------------------------


def test_a_planar_plant_is_a_hinge():
    """Gravity along the base's y pulls every joint about x, and sector stiffness may couple the axes: a
    hinge's bearing reacts both, so theta_y stays zero while theta_x moves."""
    recipe = replace(_recipe("planar6-pair"), body=Body(gravity=True, base_tilt_deg=90.0, base_azimuth_deg=45.0))
    for elastic_return in ("backbone", "sectors"):
        plant = Plant(recipe, batch=1, dynamics=JointDynamics(elastic_return=elastic_return))
        command = np.full((1, 6, 2), 80.0)
        command[0, 2, 0] += 20.0
        plant.reset(command)
        plant.advance(command, 0.3)
        assert np.all(plant.theta[..., 1] == 0.0) and np.all(plant.omega[..., 1] == 0.0)
        assert np.abs(plant.theta[0, :, 0]).max() > 1e-3


def test_step_tests_fit_the_robot():
    assert step_test("posterior-3", 12) == STEP_TESTS["posterior-3"]
    assert step_test("posterior-6", 12) == STEP_TESTS["posterior-6"]
    assert step_test("posterior-3", 6).joints == (4, 5, 6) and step_test("posterior-6", 6).joints == tuple(range(1, 7))
    with pytest.raises(ConfigError, match="modules"):
        step_test("posterior-6", 4)


def _short(recipe):
    return replace(step_test("posterior-3", recipe.robot.n_modules), hold_s=3.5, lead_s=0.5)


def _check_tracks(run, test):
    idx = np.asarray(test.joints) - 1
    for loop in (1, 2):
        m = loop_metrics(run, 0, loop)
        assert m["settle_s"] is not None and m["rms_deg"] < 0.5, m
        end = np.rad2deg(run.angles[0, run.loop_window(loop)][-1, idx] @ run.direction)
        assert np.all(np.abs(end - (test.amplitude_deg if loop == 1 else 0.0)) < 0.5)
    assert np.rad2deg(np.abs(run.angles[0])).max() < 2.0 * test.amplitude_deg  # bounded: every joint, both axes
    assert np.all(np.isfinite(run.command)) and run.joint_side.min() > 0.5 * HybridGains().pretension_n


def test_the_oracle_steps_a_planar_robot_in_x():
    """planar6-pair (2 tendons per set), the default (12-module) gains, joints 4-6 by 5 deg and back: the
    step is along x and theta_y never leaves zero; the stepped joints settle and the rest stay bounded."""
    recipe = _recipe("planar6-pair")
    test = _short(recipe)
    run = run_step_test(recipe, [OracleInLoop()], test, seed=0)
    assert run.bending_axes == 1 and abs(run.direction[0]) == 1.0 and run.direction[1] == 0.0
    assert np.all(run.angles[..., 1] == 0.0)
    assert run.joint_side.shape[-1] == 2 and run.chain.shape[-1] == 2
    _check_tracks(run, test)


def test_the_oracle_steps_a_four_tendon_robot():
    """snake6-quad (4 tendons per set), joints 4-6 by 5 deg and back, with k_p = 4 N m/rad.  The 12-module
    gains (k_p = 12) do not suit this robot: its backbone is 8 N m/rad (g r with r = 8 mm, against 12) and its
    base carries 6.6e-3 kg m^2 (against 0.11), and with them its held base joints swing up to 40 deg, the
    commands at the actuators' limit (:doc:`/guide/closed_loop`).  A 6-module robot of the same sizes with three
    tendons does the same, and a 12-module one with four does not: it is the robot's size, not its count."""
    recipe = _recipe("snake6-quad")
    test = _short(recipe)
    run = run_step_test(recipe, [OracleInLoop()], test, seed=0, gains=HybridGains(kp=4.0))
    assert run.joint_side.shape[-1] == 4 and run.sigma.shape[-1] == 4
    _check_tracks(run, test)
