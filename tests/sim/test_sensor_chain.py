"""Sensors as they are built, and friction that runs in and wears (docs/guide/simulator.rst)."""

import dataclasses

import numpy as np
import pytest

from friction_models import first_order_lowpass, run_in_wear_factor
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.geometry import RobotGeometry, tendon_azimuths
from tendon_id.sim import Effects, Sensors, simulate
from tendon_id.sim.drift import drift_factors
from tendon_id.sim.sensor_chain import SENSOR_CHAIN_EFFECTS, cell_errors, sensor_signals
from tendon_id.sim.sensor_effects import ActuatorCells, ClockSkew, FrictionDrift, LoadCellDynamics
from tendon_id.sliding import guide_sliding_distance

NEW = ("actuator_cells", "clock_skew", "load_cell_dynamics", "friction_drift")
FRAMES = 400  # planned-paths: trajectories of 315 and 85 frames; posterior-6: 4 of 100-125


@pytest.fixture(scope="module")
def quiet():
    """snake12-paper without load-cell noise, so a reading is its noise-free signal clipped."""
    return dataclasses.replace(load_recipe("snake12-paper"), sensors=Sensors(noise_n=0.0))


def _run(recipe, effects, params=None, protocol="planned-paths", seed=4):
    if params:
        eff = Effects(enabled=(), params={**recipe.effects.to_dict()["params"], **params})
        recipe = dataclasses.replace(recipe, effects=eff)
    return simulate(recipe, protocol, effects=effects, frames=FRAMES, seed=seed, progress=False).recording


def _starts(rec):
    return rec.trajectory_starts


@pytest.mark.parametrize(
    "build, match",
    [
        (lambda: ActuatorCells(gain_sd=-0.1), "actuator_cells.gain_sd"),
        (lambda: ActuatorCells(offset_sd=float("inf")), "actuator_cells.offset_sd"),
        (lambda: ActuatorCells(gain=[[0.1, 0.2], [0.1]]), "actuator_cells.gain"),
        (lambda: ActuatorCells(offset="x"), "actuator_cells.offset"),
        (lambda: ActuatorCells(gain=-1.5), "actuator_cells.gain"),
        (lambda: ClockSkew(terminal_s=1.5), "clock_skew.terminal_s"),
        (lambda: ClockSkew(angles_s="late"), "clock_skew.angles_s"),
        (lambda: LoadCellDynamics(tau_s=0.0), "load_cell_dynamics.tau_s"),
        (lambda: FrictionDrift(run_in_drop=1.0), "friction_drift.run_in_drop"),
        (lambda: FrictionDrift(run_in_length_m=0.0), "friction_drift.run_in_length_m"),
        (lambda: FrictionDrift(wear_rate_per_m=-0.1), "friction_drift.wear_rate_per_m"),
        (lambda: FrictionDrift(prior_sliding_m=-1.0), "friction_drift.prior_sliding_m"),
    ],
)
def test_bad_settings_name_the_setting(build, match):
    with pytest.raises(ConfigError, match=match.replace(".", r"\.")):
        build()


def test_the_new_effects_switch_by_name_and_keep_their_settings():
    eff = Effects(enabled=NEW, params={"clock_skew": {"actuator_s": 0.03}, "actuator_cells": {"gain": 0.01}})
    assert eff.enabled == NEW
    d = eff.to_dict()["params"]
    assert d["clock_skew"] == {"angles_s": 0.0, "actuator_s": 0.03, "terminal_s": -0.05}
    assert d["actuator_cells"]["gain"] == 0.01 and d["actuator_cells"]["offset"] is None
    assert Effects(enabled=()).to_dict() == {"enabled": [], "params": {}}  # off: recipes keep their hash


def test_cell_errors_are_drawn_from_the_seed_alone_and_given_values_win():
    cells = ActuatorCells(gain_sd=0.02, offset_sd=3.0)
    g, o = cell_errors(5, 12, cells)
    g2, o2 = cell_errors(5, 12, cells)
    np.testing.assert_array_equal(g, g2)
    np.testing.assert_array_equal(o, o2)
    assert g.shape == o.shape == (12, 3) and not np.array_equal(g, cell_errors(6, 12, cells)[0])
    assert 0.01 < g.std() < 0.03 and 1.5 < o.std() < 4.5
    g_rig, o_rig = cell_errors(5, 2, cells)  # the 2-module rig reads through the robot's first cells
    np.testing.assert_array_equal(g_rig, g[:2])
    np.testing.assert_array_equal(o_rig, o[:2])
    rows = [[0.01, -0.02, 0.0]] * 12
    g, o = cell_errors(5, 12, ActuatorCells(gain=rows, offset=1.5))
    np.testing.assert_array_equal(g, np.array(rows))
    np.testing.assert_array_equal(o, np.full((12, 3), 1.5))
    with pytest.raises(ConfigError, match="12 rows"):
        cell_errors(5, 12, ActuatorCells(gain=[[0.0, 0.0, 0.0]] * 3))


def test_without_sensor_effects_the_streams_pass_unchanged():
    x = np.ones((5, 2, 2))
    t = np.ones((5, 2, 3))
    term = np.ones((5, 3))
    out = sensor_signals(x, t, term, np.eye(5, dtype=bool)[0], Effects(enabled=("sensor_bias",)), 0.1, 0)
    assert out.theta is x and out.actuator is t and out.terminal is term and out.truth == {}


def test_actuator_gain_and_offset_are_applied_exactly(quiet):
    base = _run(quiet, "none")
    g = np.linspace(-0.03, 0.03, 36).reshape(12, 3)
    o = np.linspace(-4.0, 4.0, 36).reshape(12, 3)
    on = _run(quiet, "actuator_cells", {"actuator_cells": {"gain": g.tolist(), "offset": o.tolist()}})
    np.testing.assert_array_equal(on.actuator, (1.0 + g) * base.actuator + o)
    np.testing.assert_array_equal(on.terminal, base.terminal)  # the model's input is off, the truth is not
    np.testing.assert_array_equal(on.joint_truth[:, 1:], base.joint_truth[:, 1:])
    assert on.meta["sensor_truth"]["actuator_cells"] == {"gain": g.tolist(), "offset": o.tolist()}


def test_drawn_cell_errors_are_recorded(quiet):
    on = _run(quiet, "actuator_cells", seed=9)
    base = _run(quiet, "none", seed=9)
    truth = on.meta["sensor_truth"]["actuator_cells"]
    g, o = cell_errors(9, 12, quiet.effects.get("actuator_cells"))
    assert truth == {"gain": g.tolist(), "offset": o.tolist()}
    np.testing.assert_array_equal(on.actuator, (1.0 + g) * base.actuator + o)
    assert "sensor_truth" not in base.meta


@pytest.mark.parametrize("stream", ["angles", "actuator", "terminal"])
def test_a_skew_of_one_frame_is_a_shift_by_one_frame(quiet, stream):
    base = _run(quiet, "none")
    skew = {"angles_s": 0.0, "actuator_s": 0.0, "terminal_s": 0.0, f"{stream}_s": 0.1}
    on = _run(quiet, "clock_skew", {"clock_skew": skew})
    got, want = getattr(on, stream), getattr(base, stream)
    last = np.r_[_starts(on)[1:], True]  # each trajectory's last frame: held
    assert _starts(on).sum() >= 2
    np.testing.assert_array_equal(got[~last], want[1:][~last[:-1]])
    np.testing.assert_array_equal(got[last], want[last])
    for other in {"angles", "actuator", "terminal"} - {stream}:
        np.testing.assert_array_equal(getattr(on, other), getattr(base, other))


def test_a_half_frame_skew_reads_between_frames(quiet):
    base = _run(quiet, "none")
    on = _run(quiet, "clock_skew")  # default: the terminal cells half a frame late
    first = _starts(on)
    mid = 0.5 * (base.terminal[1:] + base.terminal[:-1])
    np.testing.assert_allclose(on.terminal[1:][~first[1:]], mid[~first[1:]], rtol=1e-12)
    np.testing.assert_array_equal(on.terminal[first], base.terminal[first])
    np.testing.assert_array_equal(on.actuator, base.actuator)


def test_load_cell_dynamics_lag_every_cell_and_restart_at_each_trajectory(quiet):
    base = _run(quiet, "none")
    on = _run(quiet, "load_cell_dynamics")
    tau = quiet.effects.get("load_cell_dynamics").tau_s
    for stream in ("actuator", "terminal"):
        want = first_order_lowpass(getattr(base, stream), quiet.dt, tau, _starts(on))
        np.testing.assert_allclose(getattr(on, stream), want, rtol=1e-12)
    np.testing.assert_array_equal(on.angles, base.angles)


def test_same_seed_same_bytes_with_every_new_effect(tmp_path):
    recipe = load_recipe("snake12-paper")
    effects = recipe.effects.enabled + NEW
    a = simulate(recipe, "posterior-6", effects=effects, frames=FRAMES, seed=7).recording
    b = simulate(recipe, "posterior-6", effects=effects, frames=FRAMES, seed=7).recording
    c = simulate(recipe, "posterior-6", effects=effects, frames=FRAMES, seed=8).recording
    pa, pb, pc = (r.write(tmp_path / f"{n}.parquet") for r, n in ((a, "a"), (b, "b"), (c, "c")))
    assert pa.read_bytes() == pb.read_bytes()
    assert pa.read_bytes() != pc.read_bytes()
    assert set(SENSOR_CHAIN_EFFECTS) <= set(a.meta["effects"]) and "sensor_truth" in a.meta


def test_a_guide_slides_as_far_as_its_tendons_paths_change():
    geometry = RobotGeometry(n_modules=2)
    dt, omega, n = 0.1, 0.05, 30  # joint 2 bends about x at 0.05 rad/s
    theta = np.zeros((n, 2, 2))
    theta[:, 1, 0] = omega * dt * np.arange(n)
    reset = np.zeros(n, dtype=bool)
    reset[0] = True
    s = guide_sliding_distance(theta, reset, geometry, dt)
    speed = geometry.hole_radius * omega * np.abs(np.cos(tendon_azimuths(geometry)[1])).mean()
    np.testing.assert_allclose(s[:, 0], speed * dt * np.arange(n), rtol=1e-9, atol=1e-15)
    fd = FrictionDrift(run_in_drop=0.3, run_in_length_m=1e-3, wear_rate_per_m=2.0, prior_sliding_m=0.01)
    w = drift_factors(theta, reset, geometry, fd, dt)
    assert w.shape == (n, 1)
    np.testing.assert_array_equal(w, run_in_wear_factor(s + 0.01, 0.3, 1e-3, 2.0))


def test_drift_factors_over_a_session(quiet):
    res = simulate(quiet, "planned-paths", effects="none", frames=FRAMES, seed=4, progress=False)
    ses = res.session
    fd = FrictionDrift()
    s = guide_sliding_distance(ses.theta, ses.reset, quiet.robot, quiet.dt)
    w = drift_factors(ses.theta, ses.reset, quiet.robot, fd, quiet.dt)
    assert w.shape == (len(ses.reset), quiet.robot.n_modules - 1)
    assert np.all(np.diff(s, axis=0) >= 0) and np.all(s[-1] > 0)
    assert np.all(w[0] == 1.0) and np.all(w[-1] < 1.0) and np.all(w > 1 - fd.run_in_drop)
    still = np.repeat(ses.theta[:1], 20, axis=0)  # a robot at rest does not wear
    np.testing.assert_array_equal(drift_factors(still, np.eye(20, dtype=bool)[0], quiet.robot, fd, quiet.dt), 1.0)
