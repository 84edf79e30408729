"""The 10 Hz hybrid tension and configuration controller (paper Section IV-C, adapted from [3]).

Two loops per joint ``k``, run once per controller period ``T_c``:

* **Configuration (outer).** PI on the joint angles, with what the joint's own set must
  overcome fed forward: the elastic return at the reference, and the moments of everything
  else acting on the joint, every distal set's tendons that pass through it, at the
  estimator's tensions ``T_hat[k, j]`` (``j > k``), and gravity::

      tau_d = -tau_e(theta_ref) + k_p e + k_i sum(e) T_c + k_d (e - e_prev) / T_c
              - tau_pass(theta, T_hat) - tau_g(theta)

  with ``e = theta_ref - theta`` (:mod:`~tendon_id.closed_loop.statics`; ``k_d`` is 0 by
  default), and ``T_hat`` the estimator's chain low-passed over a few periods
  (:class:`HybridGains`' ``chain_smoothing``: the feedforward sums many noisy cells).  This is why the
  intermediate estimates matter: a set's tendons load every joint on their way to their own,
  and the controller can only cancel that load as well as it knows their tensions there.
  The desired joint torque becomes desired joint-side tensions of the set's ``n`` tendons by the
  minimum-norm tension above the pretension ``P`` (:mod:`~tendon_id.closed_loop.distribution`)::

      T_d = P + t,   t = argmin |t|^2  s.t.  r sum_i T_d,i u_i = tau_d,  t >= 0,   u_i = (cos psi_i, sin psi_i)

  (the puller-follower scheme of [3]: the follower keeps the tendon taut).  For three tendons
  120 deg apart it is ``T_d,i = P + d_i - min_l d_l`` with ``d_i = 2 / (3 r) tau_d . u_i``.  On a
  planar robot (``bending_axes`` 1) the controller ignores ``theta_y``: its error is zero, and only
  ``tau_d``'s x part, the moment about the hinge, is distributed.
* **Tension (inner).** The estimator maps the actuator-side measurement ``a`` to an estimate
  ``T_hat`` of the joint side, and so gives the transmission's current ratio
  ``r_hat = T_hat / a``.  The command is incremental: the change of the desired joint side is
  fed forward through the inverted transmission, and the estimate's error is fed back::

      u(t) = u(t-1) + [T_d(t) - T_d(t-1)] / r_hat + k_T [T_d(t) - T_hat(t)] / r_hat

  Its fixed point is ``T_hat = T_d``: a controller is only as good as its estimator.  The
  feedback is a fraction ``k_T < 1`` of the full inversion per period because ``r_hat`` is the
  ratio, not the local gain ``dT_hat/da``: in stick the joint side does not follow the actuator
  at all, and with viscoelastic relaxation only part of a change arrives at once, so the full
  inversion (``k_T = 1``) winds the command up and hunts around the play operator's band.

[3] the hybrid tension and configuration controller the paper cites for its Section IV-C.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tendon_id.closed_loop.distribution import TensionDistribution
from tendon_id.closed_loop.statics import on_path
from tendon_id.errors import ConfigError

__all__ = ["HybridController", "HybridGains"]


@dataclass(frozen=True)
class HybridGains:
    """Gains of :class:`HybridController`, fixed once for the oracle estimator.

    The defaults were tuned with ``experiments/tune_closed_loop.py`` on the plant with the robot's
    true statics (``JointDynamics(statics="full")``, the default), with the oracle (true
    joint-side tensions) in the loop, on both step regimes and seeds 100-108 (kept apart from
    the benchmark's), taking the gains that settle in every loop with the smallest mean settling
    time, ties broken by RMS error.  Grids at the 80 N pretension: ``k_p`` 4-16, ``k_i`` 2-10,
    ``k_T`` 0.3-0.7, with and without the chain low-pass, on seeds 100-102; then eight of them on
    seeds 103-108, where ``k_p`` 8 left no loop unsettled either but was slower
    (:doc:`/guide/closed_loop`).  The earlier plant's gains (``k_p`` 32, ``k_i`` 5, ``k_T`` 0.7, no
    low-pass) diverge on it.  Every estimator is compared with these gains.

    Parameters
    ----------
    kp : float
        Proportional gain of the configuration loop [N m/rad].
    ki : float
        Integral gain [N m/(rad s)].
    k_tension : float
        Fraction of the estimate's error fed back per period in the tension loop [-], in (0, 1].
    pretension_n : float
        Joint-side tension of the slackest tendon ``P`` [N] (the paper's taut regime: a
        minimum of 62 N and a 5th percentile of 77 N). Default 80.
    integral_limit : float
        Anti-windup bound on the integral term [N m]. Default 2.
    kd : float
        Rate gain on the error's finite difference over one period [N m s/rad]. Default 0.
    chain_smoothing : float
        Fraction of each period's new chain estimate taken into the one that loads the joints
        with the distal sets' passing moments, in (0, 1]: a first-order low-pass with time constant
        ``-T_c / ln(1 - chain_smoothing)``, 0.28 s at the default 0.3.  The feedforward sums the
        noisy cells of up to 33 tendons at joint 1, each read twice in ``T_hat[k, j] / T_hat[j, j]``;
        without the filter the same gains settle more slowly (:doc:`/guide/closed_loop`).
    """

    kp: float = 12.0
    ki: float = 5.0
    k_tension: float = 0.5
    pretension_n: float = 80.0
    integral_limit: float = 2.0
    kd: float = 0.0
    chain_smoothing: float = 0.3

    def __post_init__(self) -> None:
        if min(self.kp, self.ki, self.kd) < 0 or not 0 < self.k_tension <= 1:
            raise ConfigError("controller gains need kp >= 0, ki >= 0, kd >= 0 and 0 < k_tension <= 1")
        if not 0 < self.chain_smoothing <= 1:
            raise ConfigError(f"chain_smoothing must be in (0, 1], got {self.chain_smoothing}")
        if self.pretension_n <= 0 or self.integral_limit <= 0:
            raise ConfigError("the controller needs pretension_n > 0 N and integral_limit > 0 N m")


class HybridController:
    """One robot's controller; :meth:`command` runs once per period.

    Parameters
    ----------
    gains : HybridGains
    psi : ndarray, shape (N, n)
        Tendon azimuths [rad], ``n`` tendons per set.
    hole_radius : float
        Moment arm ``r`` [m].
    robot : Plant
        The robot's statics the controller knows: its geometry (``bending_axes`` 1: a planar robot,
        whose ``theta_y`` the controller ignores), masses and elastic return
        (:meth:`~tendon_id.closed_loop.plant.Plant.elastic_moments`,
        :meth:`~tendon_id.closed_loop.plant.Plant.gravity_moments`,
        :meth:`~tendon_id.closed_loop.plant.Plant.crossing_jacobian`), never its state or friction.
    period : float
        Controller period ``T_c`` [s] (0.1 at 10 Hz).
    max_tension_n : float
        The actuators' tension limit [N].
    """

    def __init__(
        self,
        gains: HybridGains,
        psi: NDArray,
        hole_radius: float,
        robot,
        period: float,
        max_tension_n: float,
    ):
        self.gains, self.psi, self.hole_radius = gains, np.asarray(psi), float(hole_radius)
        self.robot, self.period, self.max_tension_n = robot, float(period), float(max_tension_n)
        n = self.psi.shape[0]
        self._passing = (on_path(n) & ~np.eye(n, dtype=bool))[:, :, None]  # sets j > k at joint k
        self.planar = robot.geometry.bending_axes == 1
        self.distribution = TensionDistribution(self.psi, self.hole_radius, gains.pretension_n, 1 if self.planar else 2)
        self.integral = np.zeros((self.psi.shape[0], 2))
        self.last_error: NDArray | None = None  # e(t-1) [rad]
        self.chain: NDArray | None = None  # the low-passed chain estimate [N]
        self.last_command: NDArray | None = None  # u(t-1) [N]
        self.last_desired: NDArray | None = None  # T_d(t-1) [N]

    def command(self, ref: NDArray, angles: NDArray, actuator: NDArray, estimate: NDArray) -> NDArray:
        """Actuator-side tension command [N], shape (N, n), for the next period.

        Parameters
        ----------
        ref, angles : ndarray, shape (N, 2)
            Reference and measured joint angles [rad].
        actuator : ndarray, shape (N, n)
            Measured actuator-side tensions [N].
        estimate : ndarray, shape (N, N, n)
            The estimator's chain ``T_hat[k, j, i]`` [N]; its diagonal is each set's joint side.
        """
        g = self.gains
        err = ref - angles
        if self.planar:  # a hinge has no theta_y to control
            err[:, 1] = 0.0
        self.integral = np.clip(self.integral + g.ki * err * self.period, -g.integral_limit, g.integral_limit)
        rate = np.zeros_like(err) if self.last_error is None else (err - self.last_error) / self.period
        self.last_error = err
        hold = -self.robot.elastic_moments(ref[None])[0] + g.kp * err + g.kd * rate + self.integral
        n = estimate.shape[0]
        own = estimate[np.arange(n), np.arange(n)]  # each set's joint side
        chain = np.nan_to_num(estimate)
        if self.chain is None or g.chain_smoothing == 1:
            self.chain = chain
        else:
            self.chain = self.chain + g.chain_smoothing * (chain - self.chain)
        desired = self.distribute(hold, angles, self.chain)
        ratio = own / actuator  # r_hat: the estimator's transmission of each tendon
        if self.last_command is None:  # the first period: the full inversion of the estimate
            u = desired / ratio
        else:
            u = self.last_command + (desired - self.last_desired + g.k_tension * (desired - own)) / ratio
        u = np.clip(u, 0.5 * g.pretension_n, self.max_tension_n)  # the clip is also the anti-windup
        self.last_command, self.last_desired = u, desired
        return u

    def distribute(self, hold: NDArray, angles: NDArray, estimate: NDArray) -> NDArray:
        """Desired joint-side tensions [N], shape (N, n): each joint's own set exerts ``hold`` less its load.

        The load on joint ``k`` is gravity's and that of every distal set's tendons passing through
        it, at the tension each will have there once it holds its own desired joint side: the
        desired ``T_d[j]`` carried back to joint ``k`` by the estimator's chain,
        ``T_d[j] T_hat[k, j] / T_hat[j, j]``.  The distal sets come first, so the recursion runs
        from the tip to the base, one joint at a time.  Two alternatives were tried and fail:
        loading a joint with what its distal sets read now lags one period per joint, and the
        loop hunts; loading it with their commands carries each set's tension-loop overshoot down
        the chain, amplified at every joint (noise-free, ``posterior-3``, joints of 1e-3 kg m^2 and
        first-order moments: the desired tensions of sets 1-8 reached 235-291 N within 0.3 s of
        the step, against at most 124 N this way).
        """
        n = estimate.shape[0]
        own = estimate[np.arange(n), np.arange(n)]
        shape = np.where(self._passing, np.nan_to_num(estimate) / own[None], 0.0)  # T_hat[k, j] / T_hat[j, j]
        jac = self.robot.crossing_jacobian(angles[None])[0]  # (N, N, n, 2)
        load = self.robot.gravity_moments(angles[None])[0]
        desired = np.empty(estimate.shape[1:])
        for k in range(n - 1, -1, -1):
            passing = -np.einsum("ji,jia->a", shape[k, k + 1 :] * desired[k + 1 :], jac[k, k + 1 :])
            desired[k] = self.distribution((hold[k] - load[k] - passing)[None], slice(k, k + 1))[0]
        return desired
