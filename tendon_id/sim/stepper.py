"""The truth transmission one instant at a time, with its state carried: the closed loop's plant.

:func:`~tendon_id.sim.transmit` runs a whole logged block, vectorised over time.  In closed loop
the next instant's actuator tension depends on the last one's joint side, so time cannot be
vectorised; :class:`TransmissionStepper` runs the same physics one instant at a time,
vectorised over a batch of robots, sets and tendons.  It shares the wraps and the capstan
exponent with ``transmit`` (:class:`~tendon_id.sim.transmission.GuideWraps`,
:func:`~tendon_id.sim.transmission.guide_exponent`); its two states are

* the play operator's output per guide (:doc:`/guide/simulator`, Kaneko-style nonsmooth capstan)::

      ln T[k+1](t) = clamp(ln T[k+1](t-), ln T[k](t) - phi, ln T[k](t) + phi)

  which is rate-independent, so stepping it finer than the log's 10 Hz changes nothing on a
  monotone input, and
* the viscoelastic element's relaxing part ``z`` (:func:`friction_models.viscoelastic_lag`),
  stepped exactly at the stepper's own period ``dt``;

or, with ``stick_slip.driver = "elastic"``, every tendon's segment tensions and path lengths
(:class:`tendon_id.sim.elastic.ElasticState`, the compiled pass's solver one instant at a time).

A test checks that the stepper and ``transmit`` agree on the same block to rounding.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from friction_models import bending_loss, edges_with_loss, slip_state
from tendon_id.errors import ConfigError
from tendon_id.geometry import RobotGeometry
from tendon_id.sim.drift import drift_at
from tendon_id.sim.effects import Effects
from tendon_id.sim.sensor_chain import SENSOR_CHAIN_EFFECTS
from tendon_id.sim.transmission import FrictionLaw, GuideWraps, guide_exponent, guide_mu, wear_factors
from tendon_id.sliding import guide_sliding_speed

__all__ = ["SENSOR_EFFECTS", "STEPPED_EFFECTS", "TransmissionStepper"]

#: Effects the stepper runs.  The others need a motion history (velocity_friction, the motion
#: driver of stick_slip) or an element population (the smooth edge) that is not stepped yet.
STEPPED_EFFECTS = (
    "contact",
    "stick_slip",
    "viscoelastic",
    "per_tendon_wrap",
    "guide_wear",
    "bending_stiffness",
    "friction_drift",
)
#: Effects of the load cells and clocks, not of the plant: the stepper accepts them and they change
#: nothing here (the closed loop's controller reads the plant's true tensions).
SENSOR_EFFECTS = ("sensor_bias", *SENSOR_CHAIN_EFFECTS)


class TransmissionStepper:
    """Truth transmission of a batch of robots, one instant per :meth:`step`.

    Parameters
    ----------
    geometry : RobotGeometry
    friction : FrictionLaw
    effects : Effects
        The recipe's effects; each must be in :data:`STEPPED_EFFECTS` (``sensor_bias`` is
        allowed and has no effect here).
    dt : float
        Time between steps [s] (the viscoelastic element's step).
    batch : int
        Number of independent robots.
    """

    def __init__(self, geometry: RobotGeometry, friction: FrictionLaw, effects: Effects, dt: float, batch: int):
        unsupported = [e for e in effects.enabled if e not in (*STEPPED_EFFECTS, *SENSOR_EFFECTS)]
        if unsupported:
            raise ConfigError(
                f"the closed loop cannot step the effect(s) {', '.join(unsupported)} yet; "
                f"it steps {', '.join(STEPPED_EFFECTS)} (switch the others off in the recipe)"
            )
        ss = effects.get("stick_slip") if "stick_slip" in effects else None
        if ss is not None and (ss.driver == "motion" or ss.smooth_width > 0):
            raise ConfigError(
                "the closed loop steps the sharp play operator driven by tension, or the elastic chain "
                "(stick_slip.driver = 'tension' or 'elastic', smooth_width = 0)"
            )
        if dt <= 0:
            raise ConfigError(f"the stepper's dt must be positive, got {dt} s")
        self.geometry, self.friction, self.effects = geometry, friction, effects
        self.dt, self.batch = float(dt), int(batch)
        self.stick_slip = ss is not None
        self.elastic = ss is not None and ss.driver == "elastic"
        self.visco = effects.get("viscoelastic") if "viscoelastic" in effects else None
        self.bend = effects.get("bending_stiffness").dT_b if "bending_stiffness" in effects else 0.0
        self.wear = wear_factors(geometry, effects)
        self.drift = effects.get("friction_drift") if "friction_drift" in effects else None
        self.a_visco = np.exp(-self.dt / self.visco.tau_v) if self.visco is not None else 0.0
        self.reset()

    def reset(self) -> None:
        """The next step starts from freshly pretensioned tendons: forward slip, relaxed lag."""
        n = self.geometry.n_modules
        nt = self.geometry.n_tendons
        self.play = np.zeros((self.batch, n - 1, n, nt))  # play output per guide [ln N]
        self.z = np.zeros((self.batch, n - 1, n, nt))  # viscoelastic relaxing part [N]
        self.lo, self.hi = np.zeros_like(self.play), np.zeros_like(self.play)  # the play's edges [ln N]
        # set j passes guides 1..j-1: guide index g carries set indices g+1.. (docs/guide/problem.rst)
        self._on_path = (np.arange(n)[None, :] > np.arange(n - 1)[:, None]).astype(np.int8)[None, :, :, None]
        self._crossing = (np.arange(n)[None, :] >= np.arange(n)[:, None])[None, :, :, None]  # set j crosses joint k
        # T[k, j, i] of the last step: the elastic chain's tensions, or the play chain's logs (-inf off the
        # path) turned into tensions only when read, since the earlier own-set plant never reads them.
        self._chain = np.zeros((self.batch, n, n, nt))
        self._log_chain = np.full((self.batch, n, n, nt), -np.inf)
        self.started = False
        self.slid = np.zeros((self.batch, n - 1))  # friction_drift: distance slid through each guide [m]
        self.theta_prev = None
        if self.elastic:  # the tendons' own state: segment tensions, path lengths, viscoelastic branches
            from tendon_id.sim.elastic import ElasticState  # it imports the compiled pass

            self.chain_state = ElasticState(self.geometry, self.effects, self.dt, self.batch)

    @property
    def chain(self) -> NDArray:
        """``T[k, j, i]`` [N] of the last step, shape (B, N, N, n), zero where ``k > j``."""
        if self._chain is None:
            self._chain = np.exp(self._log_chain)
            self._chain[:, 0] = self._actuator  # exactly, not exp(log(.))
        return self._chain

    def step(self, theta: NDArray, actuator: NDArray) -> tuple[NDArray, NDArray]:
        """Advance one instant.

        Parameters
        ----------
        theta : ndarray, shape (B, N, 2)
            True joint angles [rad].
        actuator : ndarray, shape (B, N, n)
            True actuator-side tensions ``T[1, j, i]`` [N], positive.

        Returns
        -------
        joint_side : ndarray, shape (B, N, n)
            ``T[j, j, i]`` [N].
        sigma : ndarray of int8, shape (B, N-1, N, n)
            Slip state per guide, set and tendon (0 where the set does not pass the guide).

        The whole chain ``T[k, j, i]`` of this instant, every tendon across every joint it crosses,
        is kept in :attr:`chain`, shape (B, N, N, n) [N], zero where ``k > j``.
        """
        n = self.geometry.n_modules
        nt = self.geometry.n_tendons
        if theta.shape != (self.batch, n, 2) or actuator.shape != (self.batch, n, nt):
            raise ConfigError(f"step needs theta ({self.batch}, {n}, 2) and actuator ({self.batch}, {n}, {nt})")
        alpha = GuideWraps(theta, self.geometry, self.effects).every()  # (B, N-1, N, n) or broadcastable
        wear = None if self.wear is None else self.wear[:, None, None]
        if self.drift is not None:  # tendon_id.sim.drift, one step at a time: the batch is the time axis there
            if self.theta_prev is not None:
                rate = (np.cumsum(theta, axis=1) - np.cumsum(self.theta_prev, axis=1)) / self.dt
                self.slid += guide_sliding_speed(rate, self.geometry) * self.dt
            wear = drift_at(self.slid, self.drift)[:, :, None, None] * (1.0 if wear is None else wear[None])
        self.theta_prev = np.array(theta, dtype=float)
        phi = guide_exponent(guide_mu(self.friction, alpha, "a guide"), alpha, self.geometry, self.effects, wear)
        phi = np.broadcast_to(phi, (self.batch, n - 1, n, nt))
        loss = bending_loss(np.broadcast_to(alpha, phi.shape), self.bend) if self.bend > 0 else None
        if self.elastic:
            seg = self.chain_state.step(theta, actuator, phi, None if loss is None else loss)
            self.started = True
            self._chain = np.concatenate([actuator[:, None], seg], axis=1) * self._crossing
            joint = actuator.copy()
            joint[:, 1:] = seg[:, np.arange(n - 1), np.arange(1, n)]
            return joint, (self._on_path * self.chain_state.sigma).astype(np.int8)
        log_t = np.log(actuator)
        self._log_chain[:, 0] = log_t
        self._chain, self._actuator = None, actuator
        for g in range(n - 1):  # guide g + 1 feeds guide g + 2: the one sequential axis
            on = slice(g + 1, n)
            x, ph = log_t[:, on], phi[:, g, on]
            lo, hi = (x - ph, x + ph) if loss is None else edges_with_loss(x - ph, x + ph, loss[:, g, on])
            if self.stick_slip:
                y = lo if not self.started else np.minimum(np.maximum(self.play[:, g, on], lo), hi)
                self.play[:, g, on] = y
                self.lo[:, g, on], self.hi[:, g, on] = lo, hi
            else:
                y = lo
            if self.visco is not None:  # z(t) = a z(t-dt) + (1 - a) T(t); starts relaxed (z = T)
                quasi = np.exp(y)
                z = quasi if not self.started else self.a_visco * self.z[:, g, on] + (1.0 - self.a_visco) * quasi
                self.z[:, g, on] = z
                y = np.log((1.0 - self.visco.kappa) * quasi + self.visco.kappa * z)
            log_t[:, on] = y
            self._log_chain[:, g + 1, on] = y  # across joint g + 2, between guides g + 1 and g + 2
        sigma = self._on_path * (slip_state(self.play, self.lo, self.hi) if self.stick_slip else np.int8(1))
        self.started = True
        return np.exp(log_t), sigma.astype(np.int8)
