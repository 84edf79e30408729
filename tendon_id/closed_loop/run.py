"""One closed-loop step test: the paper's step-and-return on a batch of simulated robots.

Every estimator drives its own robot; the robots share the seed's step direction and the
same sensor-noise draws (common random numbers), so their differences are the estimators'.
Any robot runs: ``n`` tendons per set, and a planar robot (``bending_axes`` 1) steps in x, its
bending plane, towards +x or -x as the seed draws.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from tendon_id.closed_loop.controller import HybridController, HybridGains
from tendon_id.closed_loop.estimators import InLoopEstimator
from tendon_id.closed_loop.metrics import StepMetrics, rms_error, step_metrics
from tendon_id.closed_loop.plant import JointDynamics, Plant
from tendon_id.closed_loop.statics import on_path
from tendon_id.errors import ConfigError
from tendon_id.sim import Recipe
from tendon_id.sim.motion import min_jerk_at, min_jerk_duration

__all__ = ["STEP_TESTS", "ClosedLoopRun", "StepTest", "loop_metrics", "run_step_test", "step_test"]


@dataclass(frozen=True)
class StepTest:
    """The paper's step-and-return regimes (Section IV-C, Table III).

    The reference bends every stepped joint by ``amplitude_deg`` along one direction (drawn per
    seed), holds it for ``hold_s`` (loop 1), returns to straight and holds again (loop 2).
    Each move is a minimum-jerk profile whose peak speed is the recipe's quasi-static limit
    ``v_max`` (:doc:`/guide/simulator`): duration ``1.875 A / v_max``.

    Parameters
    ----------
    regime : str
        ``"posterior-3"`` or ``"posterior-6"``.
    joints : tuple of int
        Stepped modules, 1-based.
    amplitude_deg : float
        Step size [deg].
    hold_s : float
        Length of each loop [s].
    lead_s : float
        Straight hold before the step, while the tendons are pretensioned [s].
    """

    regime: str
    joints: tuple[int, ...]
    amplitude_deg: float
    hold_s: float = 12.0
    lead_s: float = 3.0

    def __post_init__(self) -> None:
        # A zero step would divide by a zero move time and fill the reference with NaN.
        if not self.amplitude_deg > 0 or not self.hold_s > 0 or not self.lead_s >= 0:
            raise ConfigError(
                f"step test {self.regime}: amplitude_deg and hold_s must be positive and lead_s >= 0, got "
                f"{self.amplitude_deg}, {self.hold_s} and {self.lead_s}"
            )
        if not self.joints:
            raise ConfigError(f"step test {self.regime} moves no joint")

    def move_s(self, v_max_deg_s: float) -> float:
        """Duration of each move [s] at the peak speed ``v_max_deg_s`` [deg/s]."""
        return min_jerk_duration(self.amplitude_deg, v_max_deg_s)


STEP_TESTS = {
    "posterior-3": StepTest("posterior-3", (10, 11, 12), 5.0),
    "posterior-6": StepTest("posterior-6", (7, 8, 9, 10, 11, 12), 3.0),
}


def step_test(regime: str, n_modules: int) -> StepTest:
    """The regime of :data:`STEP_TESTS` on a robot of ``n_modules``: the same step on its last 3 or 6 joints.

    The paper's robot (12 modules) gets :data:`STEP_TESTS`' own tests; a 6-module robot's
    Posterior-6 steps every joint.
    """
    if regime not in STEP_TESTS:
        raise ConfigError(f"unknown step regime {regime!r}; known: {', '.join(STEP_TESTS)}")
    paper = STEP_TESTS[regime]
    k = len(paper.joints)
    if n_modules < k:
        raise ConfigError(f"step test {regime} moves {k} joints, but the robot has {n_modules} modules")
    return replace(paper, joints=tuple(range(n_modules - k + 1, n_modules + 1)))


@dataclass(frozen=True)
class ClosedLoopRun:
    """Traces of one step test, one row per estimator, sampled at the controller's rate.

    Attributes
    ----------
    estimators : list of str
    t : ndarray, shape (F,)
        Time [s].
    direction : ndarray, shape (2,)
        Unit bending direction of the step (``(+-1, 0)`` on a planar robot).
    ref : ndarray, shape (F, N, 2)
        Reference angles [rad].
    angles : ndarray, shape (E, F, N, 2)
        Measured (encoder) angles [rad].
    joint_side, estimate : ndarray, shape (E, F, N, n)
        True joint-side tensions and the estimator's [N], ``n`` tendons per set.
    chain, chain_estimate : ndarray, shape (E, F, N, N, n)
        The true chain ``T[k, j, i]`` and the estimator's [N] (zero where ``k > j``; NaN where the
        estimator gives no estimate, as a streaming engine gives only each set's own joint).
    command : ndarray, shape (E, F, N, n)
        Actuator-side commands [N].
    sigma : ndarray of int8, shape (E, F, N-1, N, n)
        True slip state per guide, set and tendon at each sample.
    bending_axes : int
        The robot's: 2, or 1 for a planar robot (whose ``theta_y`` is zero throughout).
    """

    test: StepTest
    estimators: list
    t: NDArray
    direction: NDArray
    ref: NDArray
    angles: NDArray
    joint_side: NDArray
    estimate: NDArray
    command: NDArray
    sigma: NDArray
    seed: int
    chain: NDArray | None = None
    chain_estimate: NDArray | None = None
    bending_axes: int = 2

    def traces(self) -> dict:
        """What a Fig. 6 needs, as JSON lists: the stepped joints' reference and measured angles [deg]."""
        idx = np.asarray(self.test.joints) - 1
        return {
            "t": self.t.tolist(),
            "estimators": list(self.estimators),
            "joints": list(self.test.joints),
            "direction": self.direction.tolist(),
            "amplitude_deg": self.test.amplitude_deg,
            "lead_s": self.test.lead_s,
            "hold_s": self.test.hold_s,
            "bending_axes": self.bending_axes,
            "ref_deg": np.rad2deg(self.ref[:, idx]).round(4).tolist(),
            "angles_deg": np.rad2deg(self.angles[:, :, idx]).round(4).tolist(),
        }

    def loop_window(self, loop: int) -> NDArray:
        """Boolean mask of loop 1 (step) or 2 (return) over ``t``."""
        s = self.test.lead_s + (loop - 1) * self.test.hold_s
        return (self.t >= s - 1e-9) & (self.t < s + self.test.hold_s - 1e-9)


def run_step_test(
    recipe: Recipe,
    estimators: Sequence[InLoopEstimator],
    test: StepTest,
    *,
    seed: int = 0,
    gains: HybridGains | Sequence[HybridGains] | None = None,
    dynamics: JointDynamics | None = None,
    plant_dt: float = 1e-3,
) -> ClosedLoopRun:
    """Run ``test`` with every estimator in the loop of its own robot.

    Parameters
    ----------
    recipe : Recipe
        The truth: robot, friction law, effects (with their stick/slip state carried), sensors.
    estimators : sequence of InLoopEstimator
    test : StepTest
    seed : int
        Step direction and sensor noise. The same seed gives the same bytes.
    gains : HybridGains or sequence of HybridGains, optional
        The controller's gains (default :class:`HybridGains`), or one per estimator (for tuning).
    dynamics : JointDynamics, optional
    plant_dt : float
        Plant integration step [s] (1 kHz by default; see :class:`~tendon_id.closed_loop.plant.Plant`).
    """
    if not estimators:
        raise ConfigError("a closed-loop run needs at least one estimator")
    n = recipe.robot.n_modules
    if any(not 1 <= j <= n for j in test.joints):
        raise ConfigError(f"step test {test.regime} moves joints {test.joints}, but the robot has {n} modules")
    gains = [gains or HybridGains()] * len(estimators) if not isinstance(gains, Sequence) else list(gains)
    if len(gains) != len(estimators):
        raise ConfigError(f"{len(gains)} sets of gains for {len(estimators)} estimators")
    period = recipe.dt
    seed = int(seed)
    rng = np.random.default_rng([seed, 7])  # stream 7: the step direction
    heading = rng.uniform(0.0, 2.0 * np.pi)
    direction = np.array([np.cos(heading), np.sin(heading)])
    planar = recipe.robot.bending_axes == 1
    if planar:  # a hinge bends in x alone: the seed draws which way
        direction = np.array([1.0 if direction[0] >= 0 else -1.0, 0.0])
    plant = Plant(recipe, len(estimators), dynamics, plant_dt)
    nt = plant.n_tendons
    plant.reset(np.array([np.full((n, nt), g.pretension_n) for g in gains]))
    ctrl = [
        HybridController(
            g,
            plant.psi,
            plant.geometry.hole_radius,
            plant,
            period,
            recipe.actuation.max_tension_n,
        )
        for g in gains
    ]
    for est in estimators:
        est.reset(needs_chain=plant.full)

    frames = int(round((test.lead_s + 2 * test.hold_s) / period))
    t = np.arange(frames) * period
    amp = np.deg2rad(test.amplitude_deg)
    move_s = test.move_s(recipe.v_max_deg_s)
    profile = amp * (min_jerk_at((t - test.lead_s) / move_s) - min_jerk_at((t - test.lead_s - test.hold_s) / move_s))
    ref = np.zeros((frames, n, 2))
    ref[:, np.asarray(test.joints) - 1] = profile[:, None, None] * direction

    e = len(estimators)
    angles = np.zeros((e, frames, n, 2))
    joint_side, estimate, command = (np.zeros((e, frames, n, nt)) for _ in range(3))
    chain, chain_estimate = np.zeros((e, frames, n, n, nt)), np.zeros((e, frames, n, n, nt))
    crossing = on_path(n)[:, :, None]
    diagonal = np.arange(n)
    sigma = np.zeros((e, frames, n - 1, n, nt), dtype=np.int8)
    sensors = recipe.sensors
    for f in range(frames):
        # The same noise draws for every robot (common random numbers): streams 8 and 9 per frame.
        meas_angles = sensors.read_angles(plant.theta)
        meas_act = np.stack([sensors.read_tensions(np.random.default_rng([seed, 8, f]), a) for a in plant.actuator])
        meas_chain = np.stack([_read_chain(sensors, np.random.default_rng([seed, 9, f]), c) for c in plant.chain])
        for b, (est, c) in enumerate(zip(estimators, ctrl)):
            chain_estimate[b, f] = np.where(crossing, est.step(meas_angles[b], meas_act[b], meas_chain[b]), 0.0)
            estimate[b, f] = chain_estimate[b, f][diagonal, diagonal]
            command[b, f] = c.command(ref[f], meas_angles[b], meas_act[b], chain_estimate[b, f])
        angles[:, f], joint_side[:, f], sigma[:, f] = meas_angles, plant.joint_side, plant.sigma
        chain[:, f] = plant.chain
        plant.advance(command[:, f], period)
    return ClosedLoopRun(
        test=test,
        estimators=[est.name for est in estimators],
        t=t,
        direction=direction,
        ref=ref,
        angles=angles,
        joint_side=joint_side,
        estimate=estimate,
        command=command,
        sigma=sigma,
        seed=int(seed),
        chain=chain,
        chain_estimate=chain_estimate,
        bending_axes=recipe.robot.bending_axes,
    )


def _read_chain(sensors, rng: np.random.Generator, chain: NDArray) -> NDArray:
    """The oracle's load cells on every tendon at every joint it crosses, (N, N, n) [N]: each set's own
    joint first, so those readings are the same draws whether or not the rest is read."""
    diagonal = np.arange(chain.shape[0])
    own = sensors.read_tensions(rng, chain[diagonal, diagonal])
    out = sensors.read_tensions(rng, chain)
    out[diagonal, diagonal] = own
    return out


def loop_metrics(run: ClosedLoopRun, estimator: int, loop: int, band_deg: float = 0.5) -> dict:
    """Table III's metrics of one estimator's loop 1 (step) or 2 (return).

    Rise time is the mean over the stepped joints of the 10-90 % rise of the angle projected on
    the step direction; settling time is when the last stepped joint enters the ``band_deg``
    band for good (the regime is settled when every stepped joint is); RMS error [deg] is over
    the loop's samples, the bending axes (both, or x on a planar robot) and the stepped joints,
    against the shaped reference.
    ``None`` where a joint never rises or never settles.
    """
    win = run.loop_window(loop)
    t = run.t[win] - run.t[win][0]
    idx = np.asarray(run.test.joints) - 1
    amp = run.test.amplitude_deg
    start, target = (0.0, amp) if loop == 1 else (amp, 0.0)
    y = np.rad2deg(run.angles[estimator][win][:, idx] @ run.direction)  # (F, joints)
    per_joint: list[StepMetrics] = [step_metrics(t, y[:, j], start, target, band_deg) for j in range(len(idx))]
    rises = [m.rise_s for m in per_joint]
    settles = [m.settle_s for m in per_joint]
    axes = slice(0, run.bending_axes)  # a hinge's theta_y is zero by construction: no error to average in
    ref = np.rad2deg(run.ref[win][:, idx, axes])
    return {
        "rise_s": None if None in rises else float(np.mean(rises)),
        "settle_s": None if None in settles else float(np.max(settles)),
        "rms_deg": rms_error(np.rad2deg(run.angles[estimator][win][:, idx, axes]), ref),
    }
