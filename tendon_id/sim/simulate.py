"""Simulate a protocol of a recipe into a :class:`~tendon_id.data.Recording` (:doc:`/guide/simulator`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tendon_id.checks import check_count
from tendon_id.data import Recording
from tendon_id.progress import progress_bar
from tendon_id.sim.effects import EFFECT_OPTIONS, Effects, parse_effect_names
from tendon_id.sim.motion import PathBuilder
from tendon_id.sim.protocols import PROTOCOL_NAMES, PROTOCOLS, MotionContext, held_joint_count, held_pose
from tendon_id.sim.recipe import Recipe
from tendon_id.sim.sensor_chain import SENSOR_CHAIN_EFFECTS, sensor_signals
from tendon_id.sim.sensors import apply_sensor_bias
from tendon_id.sim.transmission import transmit

_STREAM_MOTION, _STREAM_TENSION, _STREAM_NOISE, _STREAM_POSES, _STREAM_TRANSITION = range(5)


@dataclass(frozen=True)
class Session:
    """The whole simulated session behind a recording, unlogged frames included.

    With ``session = "continuous"`` the robot moves on between logged trajectories; a
    streaming estimator running all along would have seen those frames' inputs. This is
    what it would have seen, noise-free, and what the truth physics ran on.

    Attributes
    ----------
    theta : ndarray, shape (S, N, 2)
        True joint angles of every session frame [rad].
    actuator : ndarray, shape (S, N, 3)
        True actuator-side tensions [N].
    reset : ndarray of bool, shape (S,)
        Where the hysteresis and lag restart (fresh pretension).
    logged : ndarray of bool, shape (S,)
        True for the frames that are rows of the recording, in order.
    """

    theta: NDArray[np.float64]
    actuator: NDArray[np.float64]
    reset: NDArray[np.bool_]
    logged: NDArray[np.bool_]


@dataclass(frozen=True)
class SimulationResult:
    """A simulated recording and the hidden state behind it.

    Attributes
    ----------
    recording : Recording
        What a robot would log, plus intermediate joint-side truth columns.
    chain : ndarray, shape (T, N, N, 3)
        Noise-free ``T[k, j, i]`` [N] (NaN where ``k > j``).
    sigma : ndarray of int8, shape (T, N-1, N, 3)
        Slip state per guide, set and tendon (+1 forward slip, 0 stick, -1 reverse slip).
    theta_true : ndarray, shape (T, N, 2)
        Joint angles before encoder quantisation [rad].
    wrap : ndarray, shape (T, N-1)
        Backbone wrap per guide [rad].
    session : Session
        The whole session, unlogged frames included.
    """

    recording: Recording
    chain: NDArray[np.float64]
    sigma: NDArray[np.int8]
    theta_true: NDArray[np.float64]
    wrap: NDArray[np.float64]
    session: Session


def _rng(seed: int, protocol: str, trajectory: int, stream: int) -> np.random.Generator:
    # One independent stream per (seed, protocol, trajectory, purpose): a trajectory's
    # data does not depend on how many other trajectories are made.
    return np.random.default_rng([int(seed), PROTOCOL_NAMES.index(protocol), int(trajectory), stream])


def _transition(rng, theta_from, act_from, theta_to, act_to, v_max: float, dt: float) -> tuple[NDArray, NDArray]:
    """Unlogged frames between two trajectories: an idle hold, then a speed-limited move.

    Joint angles follow a minimum-jerk move; actuator tensions blend with the same
    profile from where the last trajectory ended to where the next one starts.
    """
    path = PathBuilder(theta_from, v_max, dt)
    path.hold(rng.uniform(1.0, 5.0))
    path.move_to(theta_to)
    path.hold(0.5)
    theta = path.build(path.frames)
    span = np.abs(theta - theta_from).max(axis=(1, 2))
    total = np.abs(theta_to - theta_from).max()
    s = span / total if total > 0 else np.linspace(0.0, 1.0, theta.shape[0])
    act = act_from[None] + s[:, None, None] * (act_to - act_from)[None]
    return theta, act


def simulate(
    recipe: Recipe,
    protocol: str,
    *,
    seed: int | None = None,
    effects: str | list[str] | None = None,
    frames: int | None = None,
    progress: bool | None = None,
) -> SimulationResult:
    """Simulate one protocol of a recipe.

    Parameters
    ----------
    recipe : Recipe
    protocol : str
        One of ``terminal-only``, ``posterior-3``, ``posterior-6``,
        ``planned-paths``, ``single-passage``.
    seed : int, optional
        Overrides the recipe's seed. The same seed gives the same bytes.
    effects : str or list of str, optional
        Effects to switch on instead of the recipe's (``"none"`` for none);
        their settings still come from the recipe.
    frames : int, optional
        Overrides the protocol's total frame count.
    progress : bool, optional
        Show a progress bar (default: only on a terminal).

    Returns
    -------
    SimulationResult
    """
    settings = recipe.protocol(protocol)
    if frames is not None:
        settings = type(settings)(**{**settings.__dict__, "frames": check_count("frames", frames, 2)})
    seed = recipe.seed if seed is None else check_count("seed", seed, 0)  # numpy seeds are non-negative
    eff: Effects = recipe.effects if effects is None else recipe.effects.with_enabled(parse_effect_names(effects))
    geometry = recipe.robot_for(protocol)
    n, dt = geometry.n_modules, recipe.dt
    v_max = np.deg2rad(recipe.v_max_deg_s)

    n_traj = int(np.ceil(settings.frames / settings.trajectory_frames))
    lengths = [settings.trajectory_frames] * n_traj
    lengths[-1] = settings.frames - settings.trajectory_frames * (n_traj - 1)
    if lengths[-1] < 2:  # a 1-frame tail trajectory would have no time axis: fold it in
        lengths[-2] += lengths.pop()
        n_traj -= 1

    pose_rng = _rng(seed, protocol, 0, _STREAM_POSES)
    n_held = held_joint_count(protocol, n)
    poses = [
        np.zeros((n, 2))
        if (protocol == "terminal-only" and p == 0)
        else held_pose(pose_rng, n, n_held, settings.held_pose_deg)
        for p in range(settings.n_held_poses)
    ]

    thetas, acts, ids = [], [], []
    for ti in progress_bar(range(n_traj), desc=f"simulate {protocol}", enable=progress):
        frames = type(settings)(**{**settings.__dict__, "trajectory_frames": lengths[ti]})
        ctx = MotionContext(n, frames, dt, v_max, ti, tuple(poses), geometry.bending_axes)
        theta = PROTOCOLS[protocol](_rng(seed, protocol, ti, _STREAM_MOTION), ctx)
        if geometry.bending_axes == 1:
            theta[..., 1] = 0.0  # a hinge follows only the part of a command in its plane (towards x)
        trng = _rng(seed, protocol, ti, _STREAM_TENSION)
        level = trng.uniform(*settings.pretension_n)
        thetas.append(theta)
        acts.append(recipe.actuation.tensions(trng, theta, level, geometry, dt))
        ids.append(f"{protocol}-{ti:04d}")

    # The logged trajectories are excerpts of one session: between them the robot moves on,
    # unlogged, so the hysteresis and lag states carry over (recipe.session == "continuous").
    # "fresh" restarts every trajectory from newly pretensioned tendons.
    pieces_theta, pieces_act, logged, reset_parts = [], [], [], []
    for ti in range(n_traj):
        if recipe.session == "continuous":
            gap_theta, gap_act = _transition(
                _rng(seed, protocol, ti, _STREAM_TRANSITION),
                thetas[ti - 1][-1] if ti else thetas[0][0],
                acts[ti - 1][-1] if ti else acts[0][0],
                thetas[0 if ti == 0 else ti][0],
                acts[ti][0],
                v_max,
                dt,
            )
            pieces_theta.append(gap_theta)
            pieces_act.append(gap_act)
            logged.append(np.zeros(len(gap_theta), dtype=bool))
            reset_parts.append(np.r_[ti == 0, np.zeros(len(gap_theta) - 1, dtype=bool)])
        pieces_theta.append(thetas[ti])
        pieces_act.append(acts[ti])
        logged.append(np.ones(lengths[ti], dtype=bool))
        reset_parts.append(np.r_[recipe.session == "fresh", np.zeros(lengths[ti] - 1, dtype=bool)])
    session_theta = np.concatenate(pieces_theta)
    session_act = np.concatenate(pieces_act)
    logged = np.concatenate(logged)
    reset = np.concatenate(reset_parts)
    physics = eff.with_enabled(e for e in eff.enabled if e not in SENSOR_CHAIN_EFFECTS)  # sensors act after
    tx = transmit(session_theta, session_act, reset, geometry, recipe.friction, physics, dt, keep=logged)
    chain, sigma, wrap = tx.chain, tx.sigma, tx.wrap
    theta_true, actuator_true = session_theta[logged], session_act[logged]
    session_clock = (np.arange(len(logged)) * dt)[logged]

    # Measurement: the sensors as built (lag, clock skew, cell errors), then encoders and load cells.
    starts = np.zeros(len(theta_true), dtype=bool)
    starts[np.cumsum([0, *lengths[:-1]])] = True
    signals = sensor_signals(theta_true, actuator_true, chain[:, n - 1, n - 1, :], starts, eff, dt, seed)
    nrng = _rng(seed, protocol, 0, _STREAM_NOISE)
    angles = recipe.sensors.read_angles(signals.theta)
    actuator = recipe.sensors.read_tensions(nrng, signals.actuator)
    terminal_true = signals.terminal
    t_local = np.concatenate([np.arange(m) * dt for m in lengths])
    if "sensor_bias" in eff:
        terminal_true = apply_sensor_bias(terminal_true, session_clock, eff.get("sensor_bias"))
    terminal = recipe.sensors.read_tensions(nrng, terminal_true)
    joint_truth = chain[:, np.arange(n), np.arange(n), :].copy()
    joint_truth[:, 0] = actuator[:, 0]  # set 1 has no guide: its load cell reads the joint side
    joint_truth[:, n - 1] = terminal

    meta = {
        "n_modules": n,
        "sample_rate_hz": recipe.sample_rate_hz,
        "protocol": protocol,
        "robot": geometry.to_dict(),
        "recipe": recipe.name,
        "recipe_fingerprint": recipe.fingerprint(),
        "effects": list(eff.enabled),
        # The options of an effect that a diagnosis names as effects of their own (EFFECT_OPTIONS).
        "options": [o for o in EFFECT_OPTIONS if eff.has(o)],
        "effect_params": eff.to_dict()["params"],
        "friction_truth": {"A": list(recipe.friction.A), "B": list(recipe.friction.B)},
        # Whether each logged trajectory inherits the hysteresis and lag state of unlogged motion before it.
        "session": recipe.session,
        "sensors": {
            "noise_n": recipe.sensors.noise_n,
            "range_n": recipe.sensors.range_n,
            "encoder_bits": recipe.sensors.encoder_bits,
        },
        "seed": seed,
    }
    if signals.truth:  # drawn sensor parameters (the settings are in effect_params)
        meta["sensor_truth"] = signals.truth
    trajectory = np.repeat(np.array(ids, dtype=object), lengths)
    rec = Recording.from_arrays(
        trajectory=trajectory,
        t=t_local,
        angles=angles,
        actuator=actuator,
        terminal=terminal,
        joint_truth=joint_truth,
        meta=meta,
    )
    return SimulationResult(
        recording=rec,
        chain=chain,
        sigma=sigma,
        theta_true=theta_true,
        wrap=wrap,
        session=Session(theta=session_theta, actuator=session_act, reset=reset, logged=logged),
    )
