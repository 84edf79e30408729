"""Physics invariants of the simulator (docs/guide/simulator.rst; issue acceptance)."""

import numpy as np
import pytest

from friction_models import affine_cosine_mu
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.geometry import backbone_wrap
from tendon_id.sim import EFFECT_NAMES, PROTOCOL_NAMES, simulate
from tendon_id.sim.sensor_chain import SENSOR_CHAIN_EFFECTS


@pytest.fixture(scope="module")
def recipe():
    return load_recipe("snake12-paper")


def guide_ratios(res):
    """r[t, k-1, j-1, i] = T[k+1, j, i] / T[k, j, i] (NaN off the path)."""
    c = res.chain
    with np.errstate(invalid="ignore"):
        return c[:, 1:] / c[:, :-1]


@pytest.mark.parametrize("protocol", ["posterior-6", "planned-paths"])
def test_without_effects_every_guide_ratio_is_the_capstan_law(recipe, protocol):
    res = simulate(recipe, protocol, effects="none", frames=600, seed=3)
    A, B = np.array(recipe.friction.A), np.array(recipe.friction.B)
    alpha = backbone_wrap(res.theta_true, recipe.robot.alpha_0)[..., None, None]  # (T, N-1, 1, 1)
    expected = np.exp(-affine_cosine_mu(alpha, A, B) * alpha)  # paper Eqs. (4)-(6), beta = sigma = 1
    r = guide_ratios(res)
    n = recipe.robot.n_modules
    on_path = np.arange(1, n)[:, None] < np.arange(1, n + 1)[None, :]  # guide k carries set j iff k < j
    got = r[:, on_path]
    want = np.broadcast_to(expected, r.shape)[:, on_path]
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=0)
    assert np.all(np.isnan(r[:, ~on_path]))


def test_stick_slip_ratios_stay_in_the_cone_and_sigma_says_which_edge(recipe):
    res = simulate(recipe, "posterior-3", effects="stick_slip", frames=800, seed=5)
    n = recipe.robot.n_modules
    phi = np.broadcast_to(res_phi(recipe, res), (res.chain.shape[0], n - 1, n, 3))
    r = guide_ratios(res)
    on_path = np.arange(1, n)[:, None] < np.arange(1, n + 1)[None, :]
    lo, hi = np.exp(-phi), np.exp(phi)
    rr, ll, hh, sg = r[:, on_path], lo[:, on_path], hi[:, on_path], res.sigma[:, on_path]
    assert np.all(rr >= ll * (1 - 1e-12)) and np.all(rr <= hh * (1 + 1e-12))
    np.testing.assert_allclose(rr[sg == 1], ll[sg == 1], rtol=1e-9)
    np.testing.assert_allclose(rr[sg == -1], hh[sg == -1], rtol=1e-9)
    inside = sg == 0
    assert np.all((rr[inside] > ll[inside]) & (rr[inside] < hh[inside]))
    # Steps and returns make the tendons stick and slip both ways.
    assert set(np.unique(sg)) == {-1, 0, 1}


def res_phi(recipe, res):
    A, B = np.array(recipe.friction.A), np.array(recipe.friction.B)
    alpha = backbone_wrap(res.theta_true, recipe.robot.alpha_0)[..., None, None]
    return affine_cosine_mu(alpha, A, B) * alpha


def test_set_j_passes_exactly_guides_1_to_j_minus_1(recipe):
    res = simulate(recipe, "planned-paths", effects="none", frames=300, seed=1)
    n = recipe.robot.n_modules
    phi = res_phi(recipe, res)[..., 0, :]  # (T, N-1, 3)
    cum = np.concatenate([np.zeros_like(phi[:, :1]), np.cumsum(phi, axis=1)], axis=1)  # sum over guides < j
    joint = res.chain[:, np.arange(n), np.arange(n)]
    np.testing.assert_allclose(joint / res.chain[:, 0], np.exp(-cum), rtol=1e-9)
    for j in range(1, n + 1):
        assert np.all(np.isnan(res.chain[:, j:, j - 1])), f"set {j} must not reach guide {j} or beyond"
        assert np.all(np.isfinite(res.chain[:, :j, j - 1]))


def test_set_1_joint_side_equals_its_actuator_side(recipe):
    rec = simulate(recipe, "posterior-3", frames=300, seed=2).recording
    np.testing.assert_array_equal(rec.joint_truth[:, 0], rec.actuator[:, 0])
    np.testing.assert_array_equal(rec.joint_truth[:, -1], rec.terminal)


def test_same_seed_same_bytes_and_other_seed_differs(recipe, tmp_path):
    a = simulate(recipe, "posterior-6", frames=400, seed=7).recording.write(tmp_path / "a.parquet")
    b = simulate(recipe, "posterior-6", frames=400, seed=7).recording.write(tmp_path / "b.parquet")
    c = simulate(recipe, "posterior-6", frames=400, seed=8).recording.write(tmp_path / "c.parquet")
    assert a.read_bytes() == b.read_bytes()
    assert a.read_bytes() != c.read_bytes()


@pytest.mark.parametrize("protocol", [p for p in PROTOCOL_NAMES if p != "single-passage"])
def test_protocols_are_quasi_static_and_taut(recipe, protocol):
    res = simulate(recipe, protocol, frames=3000, seed=0)
    rec = res.recording
    assert rec.n_frames == 3000 and rec.n_modules == 12
    speed = np.abs(np.diff(res.theta_true, axis=0)).max(axis=(1, 2)) * recipe.sample_rate_hz
    speed = speed[~rec.trajectory_starts[1:]]
    assert np.percentile(np.rad2deg(speed), 99) < 9.0  # paper §III-D
    assert rec.actuator.min() >= 62.0  # the paper's taut regime
    assert rec.actuator.max() < recipe.sensors.range_n  # the load cells never clip
    assert rec.terminal.min() > 0


def test_single_passage_is_a_two_module_rig(recipe):
    res = simulate(recipe, "single-passage", frames=500, seed=0)
    assert res.recording.n_modules == 2
    assert res.chain.shape[1:] == (2, 2, 3)


@pytest.mark.parametrize("effect", EFFECT_NAMES)
def test_every_effect_switches_and_changes_the_transmission(recipe, effect):
    base = simulate(recipe, "planned-paths", effects="none", frames=400, seed=4).recording
    on = simulate(recipe, "planned-paths", effects=effect, frames=400, seed=4).recording
    assert on.meta["effects"] == [effect]
    if effect in SENSOR_CHAIN_EFFECTS:  # a sensor's: the physical truth stays, a stream changes
        np.testing.assert_array_equal(on.joint_truth[:, 1:-1], base.joint_truth[:, 1:-1])
        assert any(not np.allclose(getattr(on, s), getattr(base, s)) for s in ("angles", "actuator", "terminal"))
        return
    # Inputs are identical; only the physics differs.
    np.testing.assert_array_equal(on.actuator, base.actuator)
    np.testing.assert_array_equal(on.angles, base.angles)
    assert not np.allclose(on.terminal, base.terminal, rtol=1e-6, atol=1e-6)
    if effect == "sensor_bias":  # a sensor effect leaves the physical truth alone
        np.testing.assert_array_equal(on.joint_truth[:, :-1], base.joint_truth[:, :-1])


def test_contact_gate_removes_loss_below_the_clearance(recipe):
    import dataclasses

    r = dataclasses.replace(recipe, robot=dataclasses.replace(recipe.robot, alpha_c=0.2))
    res = simulate(r, "posterior-3", effects="contact", frames=300, seed=0)
    wrap = res.wrap
    ratios = guide_ratios(res)[:, :, -1, :]  # terminal set through every guide
    np.testing.assert_allclose(ratios[wrap <= 0.2], 1.0, rtol=1e-12)
    assert np.all(ratios[wrap > 0.2] < 1.0)


def test_bad_simulation_requests(recipe):
    with pytest.raises(ConfigError, match="unknown protocol"):
        simulate(recipe, "posterior-9")
    with pytest.raises(ConfigError, match="unknown effect"):
        simulate(recipe, "posterior-3", effects="magic")
    with pytest.raises(ConfigError, match="frames"):
        simulate(recipe, "posterior-3", frames=1)


def test_sliding_speed_is_the_rate_of_path_length_beyond_the_guide():
    from tendon_id.geometry import RobotGeometry
    from tendon_id.sim.transmission import sliding_speed

    g = RobotGeometry(n_modules=4, azimuth_step=0.0)
    theta = np.zeros((5, 4, 2))
    theta[:, 2, 0] = 0.1 * np.arange(5)  # joint 3 bends towards +x at 1 rad/s (dt = 0.1 s)
    v = sliding_speed(theta, g, np.array([True, False, False, False, False]), 0.1)
    assert v.shape == (5, 3, 4, 3)
    # Tendon 1 (psi = 0) of sets 3 and 4 crosses joint 3 beyond guides 1 and 2: |r * 1 rad/s|.
    np.testing.assert_allclose(v[1:, :2, 2:, 0], g.hole_radius)
    # Tendons 2 and 3 sit at +-120 deg: cos(120 deg) = -1/2 of that rate.
    np.testing.assert_allclose(v[1:, :2, 2:, 1:], 0.5 * g.hole_radius)
    assert np.all(v[0] == 0)  # first frame of a trajectory: no rate yet
    assert np.all(v[:, 2] == 0)  # guide 3 lies beyond joint 3: nothing distal of it moves
    assert np.all(v[:, :, :2] == 0)  # sets 1 and 2 do not cross joint 3


def _three_module_scan():
    """Joint 3 bends to +x and back at 1 rad/s, with holds; actuator tensions constant."""
    from tendon_id.geometry import RobotGeometry

    geometry = RobotGeometry(n_modules=3, azimuth_step=0.0)
    ramp = 0.1 * np.arange(1, 4)  # rad, dt = 0.1 s
    bend = np.r_[np.zeros(3), ramp, np.full(4, 0.3), ramp[::-1] - 0.1, np.zeros(4)]
    theta = np.zeros((bend.size, 3, 2))
    theta[:, 0, 0] = 0.2  # joints 1 and 2 held bent, so both guides of set 3 are in contact
    theta[:, 1, 0] = 0.2
    theta[:, 2, 0] = bend
    actuator = np.full((bend.size, 3, 3), 100.0)
    reset = np.zeros(bend.size, dtype=bool)
    reset[0] = True
    return geometry, theta, actuator, reset


@pytest.mark.parametrize("driver", ["tension", "motion"])
def test_motion_driven_slip_follows_the_tendon_through_the_guides(driver):
    """With ``driver="motion"`` a tendon drawn through its guides by distal joint motion sits on
    the slip edge of its direction; with constant actuator tension the tension-driven play
    operator keeps the output it started with (docs/guide/simulator.rst)."""
    from tendon_id.sim.effects import Effects
    from tendon_id.sim.transmission import FrictionLaw, transmit

    geometry, theta, actuator, reset = _three_module_scan()
    law = FrictionLaw()
    effects = Effects(enabled=("stick_slip",), params={"stick_slip": {"driver": driver}})
    res = transmit(theta, actuator, reset, geometry, law, effects, 0.1)
    # Independent capstan exponents of set 3 (backbone wrap, paper Eqs. (3)-(5)), per frame and tendon.
    mag = np.abs(theta[..., 0])
    alpha = 0.5 * mag[:, :-1] + 0.5 * mag[:, 1:] + geometry.alpha_0  # (T, 2 guides)
    phi = affine_cosine_mu(alpha[..., None], np.array(law.A), np.array(law.B)) * alpha[..., None]
    total = phi.sum(axis=1)  # (T, 3): both guides
    log_ratio = np.log(res.chain[:, 2, 2] / actuator[:, 2])
    bending_out, bending_back = slice(3, 6), slice(10, 13)
    if driver == "tension":
        # Constant input and a cone that only widens from the start (joint 3 starts straight): the
        # output never moves from where it started, though the tendon is drawn through the
        # guides all along. Guide 2 sticks (strictly inside its cone) while joint 3 is bent.
        np.testing.assert_allclose(log_ratio, np.broadcast_to(-total[0], log_ratio.shape), atol=1e-12)
        assert np.all(res.sigma[3:12, 1, 2] == 0) and not np.any(res.sigma[:, :, 2] == -1)
        return
    # Tendon 1 (psi = 0) is on the inside of joint 3's bend: reeled in, forward slip ...
    np.testing.assert_allclose(log_ratio[bending_out, 0], -total[bending_out, 0], atol=1e-12)
    assert np.all(res.sigma[bending_out, :, 2, 0] == 1)
    # ... and paid out on the way back: reverse slip, the tension rises through the guides.
    np.testing.assert_allclose(log_ratio[bending_back, 0], total[bending_back, 0], atol=1e-12)
    assert np.all(res.sigma[bending_back, :, 2, 0] == -1)
    # Tendons 2 and 3 (psi = +-120 deg) move the other way.
    np.testing.assert_allclose(log_ratio[bending_out, 1:], total[bending_out, 1:], atol=1e-12)
    np.testing.assert_allclose(log_ratio[bending_back, 1:], -total[bending_back, 1:], atol=1e-12)
    # Holds keep the last slid state (stick): the wrap is constant there, so is the tension.
    hold = slice(7, 10)
    np.testing.assert_allclose(res.chain[hold, 2, 2], np.broadcast_to(res.chain[6, 2, 2], (3, 3)), rtol=1e-12)
    # Sets 1 and 2 do not cross joint 3: they never slide and stay on their starting edge.
    np.testing.assert_allclose(np.log(res.chain[:, 1, 1] / actuator[:, 1]), -phi[:, 0], atol=1e-12)


def test_stick_slip_driver_is_validated():
    from tendon_id.sim.effects import Effects

    with pytest.raises(ConfigError, match="driver"):
        Effects(enabled=("stick_slip",), params={"stick_slip": {"driver": "magic"}})
    with pytest.raises(ConfigError, match="slide_threshold"):
        Effects(enabled=("stick_slip",), params={"stick_slip": {"slide_threshold": 0.0}})


@pytest.mark.parametrize("session", ["continuous", "fresh"])
def test_session_holds_what_the_truth_ran_on(recipe, session):
    """``SimulationResult.session`` replays to the recorded chain on its logged frames."""
    from dataclasses import replace

    from tendon_id.sim.transmission import transmit

    rec = replace(recipe, session=session)
    res = simulate(rec, "posterior-3", frames=600, seed=3)
    ses = res.session
    assert ses.logged.sum() == res.recording.n_frames
    assert (len(ses.logged) > res.recording.n_frames) == (session == "continuous")  # unlogged moves between logs
    np.testing.assert_array_equal(ses.theta[ses.logged], res.theta_true)
    replay = transmit(
        ses.theta, ses.actuator, ses.reset, rec.robot_for("posterior-3"), rec.friction, rec.effects, rec.dt
    )
    np.testing.assert_array_equal(replay.chain[ses.logged], res.chain)
