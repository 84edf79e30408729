"""Truth physics of the tendon transmission, one frame block at a time (:doc:`/guide/simulator`).

For every set ``j`` and tendon ``i`` the guides are taken from proximal to
distal.  Through guide ``k`` the capstan exponent is

    phi = w_k * mu_i(alpha, v) * beta * alpha          (paper Eqs. (4)-(6))

and the log tension either drops by ``phi`` (forward slip) or, with
``stick_slip``, follows the play operator of the nonsmooth capstan (with a smooth edge,
``stick_slip.edge = "smooth"``: a sum of play operators of several widths).
Everything is vectorised over frames, sets and tendons; the only Python loop
runs over the ``N - 1`` guides, because guide ``k + 1`` is fed by guide ``k``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from friction_models import (
    bending_loss,
    dead_zone_wrap,
    edges_with_loss,
    guide_wear_factors,
    hard_contact_gate,
    maxwell_slip_output,
    play_operator_edges,
    slip_state,
    velocity_dependent_mu,
    viscoelastic_lag,
)
from tendon_id.errors import ConfigError
from tendon_id.geometry import (
    RobotGeometry,
    backbone_wrap,
    joint_rotation,
    projected_wrap,
    tendon_azimuths,
    turn_into_upper,
    turn_out_of_lower,
)
from tendon_id.sim import transmission_kernel as kernel
from tendon_id.sim.drift import drift_factors
from tendon_id.sim.effects import Effects
from tendon_id.sim.elastic import transmit_elastic
from tendon_id.sim.friction_law import FrictionLaw, TransmissionResult
from tendon_id.sim.sensor_chain import SENSOR_CHAIN_EFFECTS
from tendon_id.sliding import backward_rate, path_rate_at, sliding_speed, sliding_speed_at

__all__ = [
    "FrictionLaw",
    "COMPILED_EFFECTS",
    "GuideWraps",
    "TransmissionResult",
    "guide_exponent",
    "guide_mu",
    "sliding_speed",
    "transmit",
    "wear_factors",
]

#: Effects the compiled pass runs (:mod:`tendon_id.sim.transmission_kernel`); ``stick_slip`` only
#: with its sharp edge.  Anything else runs on the composed route, so a new effect needs only its block.
COMPILED_EFFECTS = (
    "contact",
    "stick_slip",
    "viscoelastic",
    "velocity_friction",
    "bending_stiffness",
    "guide_wear",
    "per_tendon_wrap",
    "sensor_bias",  # a load cell's, applied after the transmission
    "friction_drift",  # per-frame wear factors, fed in as guide_wear's
)


class GuideWraps:
    """Wrap [rad] of every guide over a block of frames, by the recipe's wrap model (:doc:`/guide/geometry`).

    Without ``per_tendon_wrap`` it is the backbone wrap of paper Eq. (3), shared by every set and
    tendon; with it, the exact turns of the hole points (``model = "exact"``) or their expansion
    to second order in the bends (``"projected"``).  Shared by :func:`transmit` and the closed loop's stepper,
    so both run the same geometry.

    Parameters
    ----------
    theta : ndarray, shape (T, N, 2)
        True joint angles [rad]; ``T`` may be frames or a batch of robots.
    geometry, effects :
        Robot and the effects that are on.
    """

    def __init__(self, theta: NDArray, geometry: RobotGeometry, effects: Effects):
        self.geometry = geometry
        self.model = effects.get("per_tendon_wrap").model if "per_tendon_wrap" in effects else None
        self.wrap = backbone_wrap(theta, geometry.alpha_0)  # (T, N-1)
        psi = tendon_azimuths(geometry)
        if self.model == "exact":
            self.R = joint_rotation(theta)
            self.ux, self.uy = geometry.hole_radius * np.cos(psi), geometry.hole_radius * np.sin(psi)
        elif self.model == "projected":
            self.projected = projected_wrap(theta, geometry, psi)  # (T, N-1 guides, N sets, n), alpha_0 included

    def at(self, g: int) -> NDArray:
        """Wrap of guide ``g + 1`` for sets ``g + 2 .. N``, broadcastable to (T, sets, n) [rad]."""
        return self._wraps(slice(g, g + 1), slice(g + 1, self.geometry.n_modules))[:, 0]

    def every(self) -> NDArray:
        """Wrap of every guide for every set, broadcastable to (T, N-1, N, n) [rad].

        Sets that do not pass a guide get a wrap too (the stepper masks them): one array
        operation for the whole chain instead of one per guide.
        """
        return self._wraps(slice(0, self.geometry.n_modules - 1), slice(0, self.geometry.n_modules))

    def _wraps(self, guides: slice, on: slice) -> NDArray:
        geo = self.geometry
        if self.model == "exact":  # turns at joint k (into link k) and joint k+1 (out of link k)
            ux, uy, h = self.ux[on], self.uy[on], 0.5 * geo.joint_gap
            lower = self.R[:, guides, None, None]
            upper = self.R[:, guides.start + 1 : guides.stop + 1, None, None]
            alpha = turn_into_upper(lower, ux, uy, h) + turn_out_of_lower(upper, ux, uy, h)
            return np.minimum(alpha + geo.alpha_0, np.pi)
        if self.model == "projected":
            return self.projected[:, guides, on]
        return self.wrap[:, guides, None, None]


def wear_factors(geometry: RobotGeometry, effects: Effects) -> NDArray | None:
    """Per-guide friction multipliers ``w_k`` of ``guide_wear``, or None when it is off."""
    if "guide_wear" not in effects:
        return None
    return guide_wear_factors(geometry.n_modules - 1, effects.get("guide_wear").guides)


def guide_mu(friction: FrictionLaw, alpha: NDArray, where: str) -> NDArray:
    """``mu_i(alpha)`` (paper Eq. (4)); refuses a law that turns negative at these wraps (``where``: which guides)."""
    mu = friction.mu(alpha)
    if np.any(mu < 0):
        raise _negative_law(float(np.max(np.broadcast_to(alpha, mu.shape)[mu < 0])), where)
    return mu


def _negative_law(alpha: float, where: str) -> ConfigError:
    return ConfigError(
        f"the friction law is negative at wraps this motion reaches ({alpha:.2f} rad at {where}); "
        "use a law with mu >= 0 there"
    )


def guide_exponent(mu: NDArray, alpha: NDArray, geometry: RobotGeometry, effects: Effects, wear=None) -> NDArray:
    """Capstan exponent ``phi = w_k mu alpha_eff`` (paper Eqs. (5)-(6), :doc:`/guide/simulator`).

    With ``contact``, ``alpha_eff`` is the clearance's dead zone ``max(alpha - alpha_c, 0)``
    (default) or the paper's gate ``beta alpha``; without it, ``alpha``.  ``wear`` is the
    guide's wear factor ``w_k`` (or factors broadcastable to ``mu``); None for 1.
    """
    if "contact" not in effects:
        a_eff = alpha
    elif effects.get("contact").gate == "dead_zone":
        a_eff = dead_zone_wrap(alpha, geometry.alpha_c)
    else:
        a_eff = alpha * hard_contact_gate(alpha, geometry.alpha_c)
    ph = mu * a_eff
    return ph if wear is None else ph * wear


def transmit(
    theta: NDArray,
    actuator: NDArray,
    reset: NDArray,
    geometry: RobotGeometry,
    friction: FrictionLaw,
    effects: Effects,
    dt: float,
    *,
    keep: NDArray | None = None,
    with_phi: bool = False,
    compiled: bool | None = None,
) -> TransmissionResult:
    """Run the truth transmission over a block of frames.

    Parameters
    ----------
    theta : ndarray, shape (T, N, 2)
        True joint angles [rad].
    actuator : ndarray, shape (T, N, n)
        True actuator-side tensions ``T[1, j, i]`` [N], all positive.
    reset : ndarray of bool, shape (T,)
        True on each trajectory's first frame (hysteresis and lag restart).
    geometry, friction, effects :
        Robot, friction law and the unmodelled effects that are on.
    dt : float
        Sample period [s].
    keep : ndarray of bool, shape (T,), optional
        Frames whose state to return (default: all); the others still run, since the
        hysteresis and lag carry over them.
    with_phi : bool
        Also return the capstan exponents (as large as ``chain``; off by default).
    compiled : bool, optional
        Run the compiled pass (:mod:`tendon_id.sim.transmission_kernel`, the same physics to
        rounding) or the composed blocks of :mod:`friction_models` (the reference).  Default:
        compiled where numba is installed and every effect that is on is in :data:`COMPILED_EFFECTS`.

    Returns
    -------
    TransmissionResult
        Of the kept frames.
    """
    can = kernel.COMPILED and _compilable(effects)
    if compiled and not can:
        raise ConfigError(
            "the compiled transmission needs numba and runs the sharp edge of stick_slip only; "
            f"effects on: {', '.join(effects.enabled) or 'none'}"
        )
    wear = wear_factors(geometry, effects)
    if "friction_drift" in effects:  # run-in and wear over the session's sliding, per frame and guide
        drift = drift_factors(theta, reset, geometry, effects.get("friction_drift"), dt)
        wear = drift if wear is None else drift * wear[None, :]
    if can if compiled is None else compiled:
        return _transmit_compiled(theta, actuator, reset, geometry, friction, effects, dt, keep, with_phi, wear)
    if "stick_slip" in effects and effects.get("stick_slip").driver == "elastic":
        res = _transmit_elastic(theta, actuator, reset, geometry, friction, effects, dt, wear)
    else:
        res = _transmit_composed(theta, actuator, reset, geometry, friction, effects, dt, wear)
    kept = slice(None) if keep is None else np.asarray(keep, dtype=bool)
    phi = res.phi[kept] if with_phi else None
    return TransmissionResult(chain=res.chain[kept], sigma=res.sigma[kept], wrap=res.wrap[kept], phi=phi)


def _compilable(effects: Effects) -> bool:
    # The load cells' and clocks' effects act on the readings (tendon_id.sim.sensor_chain), not here.
    if any(e not in COMPILED_EFFECTS and e not in SENSOR_CHAIN_EFFECTS for e in effects.enabled):
        return False
    return "stick_slip" not in effects or effects.get("stick_slip").smooth_width == 0


def _transmit_compiled(
    theta, actuator, reset, geometry, friction, effects, dt, keep, with_phi, wear
) -> TransmissionResult:
    """:func:`transmit` by the compiled pass, its error raised as the blocks raise it."""
    exact = "per_tendon_wrap" in effects and effects.get("per_tendon_wrap").model == "exact"
    wraps = None if exact else GuideWraps(theta, geometry, effects)  # the pass turns the exact wraps itself
    out = kernel.transmit_compiled(
        theta,
        actuator,
        reset,
        geometry,
        friction,
        effects,
        dt,
        keep=keep,
        with_phi=with_phi,
        wraps=None if wraps is None else wraps.every(),
        wear=wear,
    )
    bad = np.flatnonzero(out["bad_alpha"] > -np.inf)
    if bad.size:
        raise _negative_law(out["bad_alpha"][bad[0]], f"guide {bad[0] + 1}")
    kept = slice(None) if keep is None else np.asarray(keep, dtype=bool)
    return TransmissionResult(
        chain=out["chain"],
        sigma=out["sigma"],
        wrap=(backbone_wrap(theta, geometry.alpha_0) if wraps is None else wraps.wrap)[kept],
        phi=out["phi"] if with_phi else None,
    )


def guide_terms(
    g: int, wraps: GuideWraps, friction: FrictionLaw, effects: Effects, cum_rate, wear
) -> tuple[NDArray, NDArray]:
    """Wrap [rad] and capstan exponent [-] of guide index ``g`` for the sets beyond it, each (T, sets, n).

    The exponent-stage blocks of :mod:`friction_models` in the order of paper Eqs. (4)-(6):
    the friction law, its growth with sliding speed (``velocity_friction``; ``cum_rate`` is
    the running joint-angle rate :func:`~tendon_id.sliding.backward_rate` of the cumulative
    angles, or None), the clearance and the wear factor ``wear[g]`` (``wear``: per guide, or
    per frame and guide, or None).
    """
    geometry = wraps.geometry
    alpha = wraps.at(g)
    mu = guide_mu(friction, alpha, f"guide {g + 1}")
    if "velocity_friction" in effects:
        vf = effects.get("velocity_friction")
        psi = tendon_azimuths(geometry)
        speed = sliding_speed_at(cum_rate, g, psi, geometry.hole_radius)
        mu = velocity_dependent_mu(mu, speed, vf.v_ref, vf.stribeck_drop, vf.v_stribeck)
    w = None if wear is None else (wear[g] if wear.ndim == 1 else wear[:, g, None, None])
    ph = guide_exponent(mu, alpha, geometry, effects, w)
    shape = (wraps.wrap.shape[0], geometry.n_modules - g - 1, geometry.n_tendons)
    return np.broadcast_to(alpha, shape), np.broadcast_to(ph, shape)


def _transmit_elastic(theta, actuator, reset, geometry, friction, effects, dt, wear) -> TransmissionResult:
    """:func:`transmit` with the elastic chain, composed: the blocks' exponents, then each tendon's chain."""
    n, n_frames = geometry.n_modules, theta.shape[0]
    wraps = GuideWraps(theta, geometry, effects)
    cum_rate = backward_rate(np.cumsum(theta, axis=1), reset, dt) if "velocity_friction" in effects else None
    bend = effects.get("bending_stiffness").dT_b if "bending_stiffness" in effects else 0.0
    nt = geometry.n_tendons
    phi = np.full((n_frames, n - 1, n, nt), np.nan)
    loss = np.zeros((n_frames, n - 1, n, nt))
    for g in range(n - 1):
        alpha, phi[:, g, g + 1 :] = guide_terms(g, wraps, friction, effects, cum_rate, wear)
        loss[:, g, g + 1 :] = bend * alpha
    chain, sigma = transmit_elastic(theta, actuator, reset, geometry, effects, dt, phi, loss)
    return TransmissionResult(chain=chain, sigma=sigma, wrap=wraps.wrap, phi=phi)


def _transmit_composed(theta, actuator, reset, geometry, friction, effects, dt, wear=None) -> TransmissionResult:
    """:func:`transmit` by the blocks of :mod:`friction_models`, one array operation per block and guide."""
    n = geometry.n_modules
    n_frames = theta.shape[0]
    wraps = GuideWraps(theta, geometry, effects)
    psi = tendon_azimuths(geometry)
    stick_slip = "stick_slip" in effects
    slide = effects.get("stick_slip") if stick_slip and effects.get("stick_slip").driver == "motion" else None
    edge_width = effects.get("stick_slip").smooth_width if stick_slip else 0.0  # 0: the sharp play operator
    cum_rate = None
    if "velocity_friction" in effects or slide is not None:
        cum_rate = backward_rate(np.cumsum(theta, axis=1), reset, dt)  # d/dt of sum_{m<=j} theta_m
    wear = wear_factors(geometry, effects) if wear is None else wear
    bend = effects.get("bending_stiffness").dT_b if "bending_stiffness" in effects else 0.0
    visco = effects.get("viscoelastic") if "viscoelastic" in effects else None

    nt = geometry.n_tendons
    chain = np.full((n_frames, n, n, nt), np.nan)
    sigma = np.zeros((n_frames, n - 1, n, nt), dtype=np.int8)
    phi_all = np.full((n_frames, n - 1, n, nt), np.nan)
    log_t = np.log(actuator)  # (T, N sets, n): ln T[k, j] for the sets still on the path
    chain[:, 0] = actuator
    # Guide k = g + 1 carries sets j = g + 2 .. N (index g + 1 ..).  Its quantities are built
    # guide by guide, so memory stays at (T, sets, n) however long the chain.
    for g in range(n - 1):
        on = slice(g + 1, n)
        alpha, ph = guide_terms(g, wraps, friction, effects, cum_rate, wear)
        x = log_t[:, on]
        if bend > 0:
            lo, hi = edges_with_loss(x - ph, x + ph, bending_loss(alpha, bend))
        else:
            lo, hi = x - ph, x + ph
        if slide is not None:
            # A tendon sliding through the guide sits on the edge of its direction of motion:
            # its step map is the constant map onto that edge (forward: lo, reverse: hi).
            v = path_rate_at(cum_rate, g, psi, geometry.hole_radius)
            fwd, rev = v < -slide.slide_threshold, v > slide.slide_threshold
            if edge_width > 0:  # every element of the contact slides with the tendon
                y, sig = maxwell_slip_output(lo, hi, reset, edge_width, sliding=fwd.astype(int) - rev.astype(int))
            else:
                y = play_operator_edges(np.where(rev, hi, lo), np.where(fwd, lo, hi), reset).log_out
                sig = slip_state(y, lo, hi)
        elif edge_width > 0:  # the smooth edge: the contact's elements slip one after another
            y, sig = maxwell_slip_output(lo, hi, reset, edge_width)
        elif stick_slip:
            res = play_operator_edges(lo, hi, reset)
            y, sig = res.log_out, res.sigma
        else:
            y, sig = lo, np.ones(lo.shape, dtype=np.int8)
        if visco is not None:
            y = np.log(viscoelastic_lag(np.exp(y), dt, visco.tau_v, visco.kappa, reset))
        sigma[:, g, on] = sig
        phi_all[:, g, on] = ph
        log_t[:, on] = y
        chain[:, g + 1, on] = np.exp(y)
    return TransmissionResult(chain=chain, sigma=sigma, wrap=wraps.wrap, phi=phi_all)
