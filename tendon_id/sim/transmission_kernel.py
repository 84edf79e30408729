"""The truth transmission as one compiled pass over frames, guides, sets and tendons.

:func:`~tendon_id.sim.transmission.transmit` composes the physics from blocks of
:mod:`friction_models`, one array operation per block and guide: about twenty passes over
``(T, sets, n)`` arrays per guide, each paying a transcendental function per element.  This
module runs the same physics frame by frame in one loop compiled by numba (Lam, Pitrou &
Seibert, LLVM-HPC 2015), where every quantity of a guide is used while it is in a register.
It is what makes a million frames a matter of seconds (the load check of :doc:`/guide/benchmarks`); the composed
route stays the reference, and the tests hold the two to rounding for every effect it runs.

Three rewrites, each exact in real arithmetic, save most of the transcendental calls:

* **the tension domain.**  The log is monotone, so the play operator of paper §III-B,
  ``ln T' = clamp(ln T'(t-), ln T - phi, ln T + phi)``, is ``T' = clamp(T'(t-), T e^-phi,
  T e^phi)``; the bending loss (:func:`friction_models.edges_with_loss`) and the Zener lag
  (:func:`friction_models.viscoelastic_lag`) are defined on tensions anyway.  One ``exp`` per
  element instead of seven ``exp``/``log``.
* **one angle per guide.**  A guide's two hole turns (:func:`tendon_id.geometry.turn_into_upper`,
  :func:`~tendon_id.geometry.turn_out_of_lower`) are the arguments of ``z1 + i r1`` and
  ``z2 + i r2``; their sum is the argument of the product, one ``atan2`` instead of two.
* ``hypot(x, y)`` as ``sqrt(x^2 + y^2)``: the hole offsets are centimetres, far from overflow.

What it runs: every effect of :data:`COMPILED_EFFECTS` with the sharp edge of ``stick_slip``
(any driver; the elastic one by :func:`friction_models.elastic_chain.elastic_chain_frame`,
compiled).  The smooth edge (a population of play operators per guide) runs on the composed route.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from friction_models import SLACK_FLOOR_N
from friction_models.elastic_chain import elastic_chain_frame
from tendon_id.geometry import tendon_azimuths
from tendon_id.sliding import backward_rate, segment_length

try:  # pragma: no cover - which branch runs depends on the install
    import numba
except ImportError:  # pragma: no cover
    numba = None

__all__ = ["COMPILED", "contact_mode", "elastic_chain_frame", "segment_length", "transmit_compiled"]

#: Whether the compiled pass is available (numba importable).
COMPILED = numba is not None
#: Wrap models of the pass: the exact turns of the hole points, or wraps handed in.
WRAP_GIVEN, WRAP_EXACT = 0, 1
#: Slip models of the pass: none (forward slip), the play operator driven by tension, or by motion
#: too, or the elastic tendon through capstan bands (:mod:`friction_models.elastic_chain`).
SLIP_NONE, SLIP_TENSION, SLIP_MOTION, SLIP_ELASTIC = 0, 1, 2, 3
#: Contact models of the pass: none, the paper's hard gate, the clearance's dead zone.
GATE_NONE, GATE_HARD, GATE_DEAD_ZONE = 0, 1, 2


def contact_mode(effects) -> int:
    """The pass's contact model for the ``contact`` effect's gate (it must be on)."""
    return GATE_DEAD_ZONE if effects.get("contact").gate == "dead_zone" else GATE_HARD


def _turn_into(R, m, ux, uy, h):  # pragma: no cover - compiled
    # The turn at joint m into the upper link of a hole at (ux, uy), as the (radial, axial) components
    # of the segment (tendon_id.geometry.turn_into_upper, written out the same way; _turn_out likewise
    # turn_out_of_lower).
    vx = ux - (R[m, 0] * ux + R[m, 3] * uy - R[m, 6] * h)
    vy = uy - (R[m, 1] * ux + R[m, 4] * uy - R[m, 7] * h)
    vz = h - (R[m, 2] * ux + R[m, 5] * uy - R[m, 8] * h)
    return math.sqrt(vx * vx + vy * vy), vz


def _turn_out(R, m, ux, uy, h):  # pragma: no cover - compiled
    sx = R[m, 0] * ux + R[m, 1] * uy + R[m, 2] * h - ux
    sy = R[m, 3] * ux + R[m, 4] * uy + R[m, 5] * h - uy
    sz = R[m, 6] * ux + R[m, 7] * uy + R[m, 8] * h + h
    return math.sqrt(sx * sx + sy * sy), sz


def _pass(
    theta, actuator, restart, row, ux, uy, h, alpha_0, alpha_given, wrap_mode,
    A, B, contact, alpha_c, wear, vf, v_ref, drop, v_s, cum_rate, cos_psi, sin_psi, hole_r,
    slip, slide_threshold, bend, floor, visco, a_lag, kappa, k_seg,
    chain, sigma, phi, bad_alpha,
):  # fmt: skip  # pragma: no cover - compiled
    n_frames, n, nt = actuator.shape[0], actuator.shape[1], actuator.shape[2]  # nt: tendons per set
    R = np.empty((n, 9))
    play = np.zeros((n - 1, n, nt))  # the play operator's output per guide [N] (elastic: segment tensions)
    z = np.zeros((n - 1, n, nt))  # the Zener element's relaxing part [N] (elastic: the Maxwell branch's force)
    tension = np.empty((n, nt))
    elastic = slip == SLIP_ELASTIC
    m = n - 1 if elastic else 0  # the elastic chain's per-frame buffers: exponent, loss, length change, length
    phi_b, loss_b = np.zeros((m, n, nt)), np.zeros((m, n, nt))
    dl_b, len_prev = np.zeros((m, n, nt)), np.zeros((m, n, nt))
    scratch = np.empty((5, m))
    cc, kk, cp, em, ep = scratch[0], scratch[1], scratch[2], scratch[3], scratch[4]
    sg_s = np.zeros(m, dtype=np.int8)
    kk[:] = k_seg
    worn = wear.shape[0] > 1
    wide, deep = alpha_given.shape[2] > 1, alpha_given.shape[3] > 1
    cos_a0, sin_a0 = math.cos(alpha_0), math.sin(alpha_0)
    with_phi = phi.shape[0] > 0
    for t in range(n_frames):
        k, first = row[t], restart[t]
        if wrap_mode == WRAP_EXACT or elastic:  # joint_rotation: R = R_y(theta_x) R_x(-theta_y), row-major
            for m in range(n):
                ca, sa = math.cos(theta[t, m, 0]), math.sin(theta[t, m, 0])
                cb, sb = math.cos(theta[t, m, 1]), math.sin(theta[t, m, 1])
                R[m, 0], R[m, 1], R[m, 2] = ca, -sa * sb, sa * cb
                R[m, 3], R[m, 4], R[m, 5] = 0.0, cb, sb
                R[m, 6], R[m, 7], R[m, 8] = -sa, -ca * sb, ca * cb
        for j in range(n):
            for i in range(nt):
                tension[j, i] = actuator[t, j, i]
        if k >= 0:  # off the path (set j does not reach guide g): NaN, and no slip state
            for j in range(n):
                for i in range(nt):
                    chain[k, 0, j, i] = actuator[t, j, i]
                    for g in range(j + 1, n):
                        chain[k, g, j, i] = np.nan
                    for g in range(j, n - 1):
                        sigma[k, g, j, i] = 0
                        if with_phi:
                            phi[k, g, j, i] = np.nan
        for g in range(n - 1):
            for j in range(g + 1, n):
                for i in range(nt):
                    r2, z2 = 0.0, 0.0
                    if wrap_mode == WRAP_EXACT or elastic:
                        r2, z2 = _turn_out(R, g + 1, ux[j, i], uy[j, i], h)
                    if wrap_mode == WRAP_EXACT:
                        r1, z1 = _turn_into(R, g, ux[j, i], uy[j, i], h)
                        im = r1 * z2 + r2 * z1  # (z1 + i r1)(z2 + i r2): the argument adds up
                        re = z1 * z2 - r1 * r2
                        if re > 0.0 and im >= 0.0:  # the turns add up to less than pi/2 (always, for a snake)
                            turn = math.atan(im / re)
                        else:  # atan2's upper half plane; im < 0 only past pi, where the wrap is capped
                            turn = math.atan2(im, re) if im >= 0.0 else math.pi
                        alpha = turn + alpha_0
                        if alpha < math.pi:  # cos(turn + alpha_0), with cos(turn) = re/|p|, sin(turn) = im/|p|
                            cos_alpha = (re * cos_a0 - im * sin_a0) / math.sqrt(re * re + im * im)
                        else:
                            alpha, cos_alpha = math.pi, -1.0
                    else:  # given (T, N-1, 1 or N, 1 or n): broadcast by index
                        alpha = alpha_given[t, g, j if wide else 0, i if deep else 0]
                        cos_alpha = math.cos(alpha)
                    mu = A[i] * cos_alpha + B[i]  # paper Eq. (4)
                    if mu < 0.0 and alpha > bad_alpha[g]:
                        bad_alpha[g] = alpha
                    v = 0.0
                    if vf or slip == SLIP_MOTION:  # path rate beyond the guide (tendon_id.sliding.path_rate_at)
                        b0 = cum_rate[t, j, 0] - cum_rate[t, g, 0]
                        b1 = cum_rate[t, j, 1] - cum_rate[t, g, 1]
                        v = -hole_r * (b0 * cos_psi[j, i] + b1 * sin_psi[j, i])
                        if vf:  # friction_models.velocity_dependent_mu
                            s = abs(v)
                            dip = drop * (1.0 - math.exp(-((s / v_s) ** 2))) if drop > 0.0 else 0.0
                            mu = mu * (1.0 - dip + s / v_ref)
                    # paper Eqs. (5)-(6): phi = w_k mu beta alpha; the dead zone: w_k mu max(alpha - alpha_c, 0)
                    if contact == GATE_DEAD_ZONE:
                        a_eff = alpha - alpha_c if alpha > alpha_c else 0.0
                    elif contact == GATE_HARD:
                        a_eff = alpha if alpha > alpha_c else 0.0
                    else:
                        a_eff = alpha
                    p = mu * a_eff * wear[t if worn else 0, g]
                    if elastic:  # the chain is solved once every guide's band is known (below)
                        phi_b[g, j, i] = p
                        loss_b[g, j, i] = bend * alpha
                        seg = math.sqrt(r2 * r2 + z2 * z2)  # the segment across joint g + 2 [m]
                        dl_b[g, j, i] = 0.0 if first else seg - len_prev[g, j, i]
                        len_prev[g, j, i] = seg
                        if k >= 0 and with_phi:
                            phi[k, g, j, i] = p
                        continue
                    x = tension[j, i]
                    e = math.exp(-p)
                    lo, hi = x * e, x / e
                    if bend > 0.0:  # friction_models.edges_with_loss, in tensions
                        loss = bend * alpha
                        lo, hi = max(lo - loss, floor), hi + loss
                    if slip == SLIP_NONE:
                        y = lo
                        sg = 1
                    else:
                        lo_e, hi_e = lo, hi
                        if slip == SLIP_MOTION:  # a sliding tendon sits on the edge of its direction
                            if v > slide_threshold:
                                lo_e = hi
                            if v < -slide_threshold:
                                hi_e = lo
                        y = lo_e if first else min(max(play[g, j, i], lo_e), hi_e)
                        play[g, j, i] = y
                        sg = 1 if y <= lo else (-1 if y >= hi else 0)  # friction_models.slip_state
                    if visco:  # friction_models.viscoelastic_lag, one exact step
                        zz = y if first else a_lag * z[g, j, i] + (1.0 - a_lag) * y
                        z[g, j, i] = zz
                        y = (1.0 - kappa) * y + kappa * zz
                    tension[j, i] = y
                    if k >= 0:
                        chain[k, g + 1, j, i] = y
                        sigma[k, g, j, i] = sg
                        if with_phi:
                            phi[k, g, j, i] = p
        if elastic:  # each tendon's chain, its state in play (tensions) and z (branches), in place
            for j in range(1, n):
                for i in range(nt):
                    elastic_chain_frame(
                        actuator[t, j, i], play[:j, j, i], z[:j, j, i], dl_b[:j, j, i], phi_b[:j, j, i],
                        loss_b[:j, j, i], kk[:j], first, a_lag, kappa if visco else 0.0, floor,
                        cc[:j], cp[:j], em[:j], ep[:j], sg_s[:j],
                    )  # fmt: skip
                    if k >= 0:
                        for q in range(j):
                            chain[k, q + 1, j, i] = play[q, j, i]
                            sigma[k, q, j, i] = sg_s[q]


if COMPILED:
    _turn_into = numba.njit(cache=True, inline="always")(_turn_into)
    _turn_out = numba.njit(cache=True, inline="always")(_turn_out)
    elastic_chain_frame = numba.njit(cache=True, inline="always")(elastic_chain_frame)
    _pass = numba.njit(cache=True, nogil=True)(_pass)


def transmit_compiled(
    theta, actuator, reset, geometry, friction, effects, dt, *, keep, with_phi, wraps, wear
) -> dict[str, NDArray]:
    """Run the compiled pass; the arguments are :func:`~tendon_id.sim.transmission.transmit`'s.

    Parameters
    ----------
    theta, actuator, reset, geometry, friction, effects, dt, keep, with_phi :
        As for ``transmit``.
    wraps : ndarray, shape (T, N-1, 1 or N, 1 or n), or None
        The wraps of the recipe's wrap model [rad]; None for the exact turns, which the pass
        computes itself.
    wear : ndarray, shape (N-1,) or (T, N-1), or None
        Friction multipliers ``w_k`` of ``guide_wear`` (and of friction drift, per frame); None for 1.

    Returns
    -------
    dict
        ``chain`` (K, N, N, n) [N], ``sigma`` (K, N-1, N, n), ``phi`` (K or 0, N-1, N, n) of the
        K kept frames, and ``bad_alpha`` (N-1,): per guide, the largest wrap [rad] where the
        friction law was negative (-inf where it never was).
    """
    if not COMPILED:  # pragma: no cover
        raise RuntimeError("the compiled transmission needs numba")
    n, nt = geometry.n_modules, geometry.n_tendons
    theta = np.ascontiguousarray(theta, dtype=float)
    restart = np.array(reset, dtype=bool)
    restart[0] = True  # frame 0 starts taut, as the play operator and the lag do
    kept = np.ones(theta.shape[0], dtype=bool) if keep is None else np.asarray(keep, dtype=bool)
    psi = tendon_azimuths(geometry)
    ss = effects.get("stick_slip") if "stick_slip" in effects else None
    vf, visco = effects.get("velocity_friction"), effects.get("viscoelastic")
    k = int(kept.sum())
    out = {
        "chain": np.empty((k, n, n, nt)),
        "sigma": np.empty((k, n - 1, n, nt), dtype=np.int8),
        "phi": np.empty((k if with_phi else 0, n - 1, n, nt)),
        "bad_alpha": np.full(n - 1, -np.inf),
    }
    needs_rate = "velocity_friction" in effects or (ss is not None and ss.driver == "motion")
    _pass(
        theta=theta,
        actuator=np.ascontiguousarray(actuator, dtype=float),
        restart=restart,
        row=np.where(kept, np.cumsum(kept) - 1, -1).astype(np.int64),
        ux=geometry.hole_radius * np.cos(psi),
        uy=geometry.hole_radius * np.sin(psi),
        h=0.5 * geometry.joint_gap,
        alpha_0=float(geometry.alpha_0),
        alpha_given=np.zeros((1, 1, 1, 1)) if wraps is None else np.ascontiguousarray(wraps, dtype=float),
        wrap_mode=WRAP_EXACT if wraps is None else WRAP_GIVEN,
        A=np.array(friction.A, dtype=float),
        B=np.array(friction.B, dtype=float),
        contact=GATE_NONE if "contact" not in effects else contact_mode(effects),
        alpha_c=float(geometry.alpha_c),
        wear=np.ones((1, n - 1)) if wear is None else np.ascontiguousarray(np.atleast_2d(wear), dtype=float),
        vf="velocity_friction" in effects,
        v_ref=float(vf.v_ref),
        drop=float(vf.stribeck_drop),
        v_s=float(vf.v_stribeck),
        cum_rate=backward_rate(np.cumsum(theta, axis=1), restart, dt) if needs_rate else np.zeros((1, n, 2)),
        cos_psi=np.cos(psi),
        sin_psi=np.sin(psi),
        hole_r=float(geometry.hole_radius),
        slip=SLIP_NONE
        if ss is None
        else {"tension": SLIP_TENSION, "motion": SLIP_MOTION, "elastic": SLIP_ELASTIC}[ss.driver],
        slide_threshold=float(effects.get("stick_slip").slide_threshold),
        bend=float(effects.get("bending_stiffness").dT_b) if "bending_stiffness" in effects else 0.0,
        floor=float(SLACK_FLOOR_N),
        visco="viscoelastic" in effects,
        a_lag=float(np.exp(-dt / visco.tau_v)),
        kappa=float(visco.kappa),
        k_seg=float(effects.get("stick_slip").EA) / segment_length(geometry),
        **out,
    )
    return out
