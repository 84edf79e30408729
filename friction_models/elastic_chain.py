"""An elastic tendon through a chain of guides, each holding a capstan band: one quasi-static frame.

A tendon runs from its actuator through guides ``1..n`` to its anchor.  Segment ``s``
(``s = 1..n``, between guide ``s`` and the next guide or the anchor) is a linear spring of
stiffness ``k_s = EA / l_s`` [N/m]; segment 0, at the actuator, carries the actuator tension
``T_0``, which the actuator's controller sets.  At guide ``s`` the capstan band holds
(Euler–Eytelwein with stick, paper §III-B):

* while the guide sticks, no tendon passes it and ``T_{s-1} e^{-phi_s} <= T_s <= T_{s-1} e^{phi_s}``;
* material passes towards the actuator only on the lower edge ``T_s = T_{s-1} e^{-phi_s}``
  (forward slip, ``sigma = +1``) and towards the anchor only on the upper edge (reverse slip,
  ``sigma = -1``).

This is the lumped form of the elastic tendon-sheath with Coulomb friction (Kaneko, Paetsch &
Tolle, "Input-dependent stability of joint torque control of tendon-driven robot hands", IEEE
Trans. Ind. Electron. 39(2):96-104, 1992; Agrawal, Peine & Yao, "Modeling of transmission
characteristics across a cable-conduit system", IEEE Trans. Robot. 26(5):914-924, 2010, whose
distributed model it discretises at the guides, where the contact is).

One frame.  Over a frame the segments' path lengths change by ``dL_s`` (the joints move) and
material ``p_s`` passes guide ``s`` towards the actuator, so (linear elasticity, strains below 1 %)

    T_s = c_s + k_s (p_s - p_{s+1}),    c_s = T_s(t-) + k_s dL_s,    p_{n+1} = 0,

where ``c_s`` is the tension segment ``s`` would have if no guide let material through.  Solved
from the anchor back: given the tension ``x`` of segment ``s-1``, the tension of segment ``s`` is
``f_s(x) = clamp(c'_s, x e^{-phi_s}, x e^{phi_s})``, where ``c'_s`` is its tension while guide
``s`` sticks and every guide beyond it does what the band makes it do.  ``c'_s`` is the root of
the strictly increasing, piecewise-linear

    h_s(y) = y + k_s sum_{r>s} (F_r(y) - c_r) / k_r - c_s,      F_r = f_r o ... o f_{s+1},

(the material that segment ``s`` gives to the segments beyond it), found by Newton's method
inside a bracket, which ends in finitely many steps on a piecewise-linear function: ``h_s`` is
affine on the piece where every guide beyond keeps its state, so a step that stays in its
piece lands on the root and ends the search without another pass.  The sum
stops at the first guide beyond ``s`` that sticks: no material passes it, so the segments from
there on give none in all (``sum_{q>=r} (T_q - c_q) / k_q = p_r = 0``).  Then
``T_1 = f_1(T_0)``, ``T_2 = f_2(T_1)`` and so on.  With ``dL = 0`` this is the play operator
of each guide in turn (the tension driver, any stiffness); for ``k -> inf`` a tendon whose
path beyond a guide lengthens is drawn through it (the motion driver).

Viscoelastic tendon (optional): each segment is a standard linear solid (Zener 1948), a spring
``(1 - kappa) k_s`` in parallel with a Maxwell branch ``kappa k_s`` whose force ``f`` relaxes with
time constant ``tau``: over a frame ``f -> a f + kappa k_s dd`` with ``a = exp(-dt / tau)`` and
``dd`` the segment's stretch.  The branch's relaxation enters ``c_s`` as ``-(1 - a) f``; the band
still clamps every tension, so the output never leaves the Coulomb band.

The functions are scalar loops on numpy arrays, so that the simulator can compile them with
numba (:mod:`tendon_id.sim.elastic_kernel`); called as they are, they are the reference.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["ELASTIC_TOL_N", "elastic_chain", "elastic_chain_frame"]

#: Tolerance of the equilibrium [N]: each root ``c'_s`` is found to within this, relative to the
#: size of the tensions that enter it (and never below 1e-9 N).
ELASTIC_TOL_N = 1e-9


def elastic_chain_frame(
    t_in, tension, branch, d_length, phi, loss, k, first, a_lag, kappa, floor, c, cp, em, ep, sigma
):
    """One frame of one tendon: its segments' tensions and viscoelastic branches, updated in place.

    The whole step of the module docstring: on a tendon's first frame it starts taut (every guide
    on its forward-slip edge); after it, the trial tensions ``c_s``, the equilibrium, and the
    standard linear solid's branch.  One function with no calls, so that numba compiles it whole
    (:mod:`tendon_id.sim.transmission_kernel`, :mod:`tendon_id.sim.elastic`).

    Parameters
    ----------
    t_in : float
        Actuator tension ``T_0`` [N].
    tension : ndarray, shape (n,)
        Segment tensions ``T_1..T_n`` [N]: the last frame's on entry, this frame's on return.
    branch : ndarray, shape (n,)
        Force of each segment's Maxwell branch [N] (0 for an elastic tendon), updated likewise.
    d_length : ndarray, shape (n,)
        Change of each segment's path length since the last frame [m].
    phi : ndarray, shape (n,)
        Capstan exponents of guides ``1..n`` [-], ``>= 0``.
    loss : ndarray, shape (n,)
        Tension-independent loss widening each band [N] (bending stiffness; 0 for none).
    k : ndarray, shape (n,)
        Segment stiffnesses [N/m].
    first : bool
        The tendon's first frame (a reset): start taut, ignore the state.
    a_lag, kappa : float
        ``exp(-dt / tau)`` and the relaxing fraction of the standard linear solid [-].
    floor : float
        Lowest tension a band's lower edge reaches [N] (a cable does not push).
    c, cp, em, ep : ndarray, shape (n,)
        Scratch space.
    sigma : ndarray of int8, shape (n,)
        Receives each guide's slip state (+1 forward, 0 stick, -1 reverse).
    """
    n = tension.shape[0]
    if first:
        x = t_in
        for s in range(n):
            x = max(x * math.exp(-phi[s]) - loss[s], floor)
            tension[s], branch[s], sigma[s] = x, 0.0, 1
        return
    for s in range(n):  # the trial tensions: no material through any guide, the branches relaxing
        c[s] = tension[s] + k[s] * d_length[s] - (1.0 - a_lag) * branch[s]
    n = c.shape[0]
    for r in range(n):
        ep[r] = math.exp(phi[r])
        em[r] = 1.0 / ep[r]
    for s in range(n - 1, -1, -1):
        y, lo_y, hi_y = c[s], -math.inf, math.inf
        for it in range(200):
            # g = h_s(y) - c_s and its slope: y plus the material segment s gives beyond guide s,
            # times k_s; f_r of each guide beyond, composed outwards (one loop: numba compiles it).
            # [y_lo, y_hi] is the piece of h_s around y: where every guide beyond keeps its state.
            g, dg, size, x, dx = y - c[s], 1.0, abs(y) + abs(c[s]), y, 1.0
            y_lo, y_hi = -math.inf, math.inf
            for r in range(s + 1, n):
                lo, hi, dlo, dhi = x * em[r] - loss[r], x * ep[r] + loss[r], dx * em[r], dx * ep[r]
                if lo < floor:  # x and the edges are affine in y: each test bounds the piece
                    if dlo > 0.0:
                        y_hi = min(y_hi, y + (floor - lo) / dlo)
                    lo, dlo = floor, 0.0
                elif dlo > 0.0:
                    y_lo = max(y_lo, y + (floor - lo) / dlo)
                if cp[r] <= lo:
                    if dlo > 0.0:
                        y_lo = max(y_lo, y + (cp[r] - lo) / dlo)
                    x, dx = lo, dlo
                elif cp[r] >= hi:
                    if dhi > 0.0:
                        y_hi = min(y_hi, y + (cp[r] - hi) / dhi)
                    x, dx = hi, dhi
                else:  # guide r sticks: no material passes it, so segments r.. give none in all
                    if dlo > 0.0:
                        y_hi = min(y_hi, y + (cp[r] - lo) / dlo)
                    if dhi > 0.0:
                        y_lo = max(y_lo, y + (cp[r] - hi) / dhi)
                    break
                kr = k[s] / k[r]
                g += (x - c[r]) * kr
                dg += dx * kr
                size += abs(c[r]) * kr
            if it == 0:  # h_s has slope >= 1: its root lies within |g| of c_s, on the side g points to
                lo_y, hi_y = (y - g, y) if g > 0.0 else (y, y - g)
            elif g > 0.0:
                hi_y = y
            else:
                lo_y = y
            tol = max(ELASTIC_TOL_N, 1e-13 * size)
            if abs(g) <= tol or hi_y - lo_y <= tol:
                break
            y_new = y - g / dg  # Newton; bisection where it would leave the bracket
            if y_lo <= y_new <= y_hi:  # h_s is affine on the piece: the step lands on its root
                y = y_new
                break
            y = y_new if lo_y < y_new < hi_y else 0.5 * (lo_y + hi_y)
        cp[s] = y
    x = t_in
    for s in range(n):
        lo, hi = max(x * em[s] - loss[s], floor), x * ep[s] + loss[s]
        y = min(max(cp[s], lo), hi)
        # On an edge to within the solver's tolerance is slip: the root c'_s is only that exact.
        tol = max(ELASTIC_TOL_N, 1e-12 * hi)
        sigma[s] = 1 if y <= lo + tol else (-1 if y >= hi - tol else 0)
        # The branch takes kappa k times the change of the segment's stretch, (T_s - c_s) / k_s + dL_s.
        branch[s] = a_lag * branch[s] + kappa * (y - c[s] + k[s] * d_length[s])
        tension[s] = y
        x = y


def elastic_chain(
    t_in: NDArray,
    d_length: NDArray,
    phi: NDArray,
    stiffness: NDArray,
    reset: NDArray,
    *,
    loss: NDArray | None = None,
    dt: float = 0.1,
    tau: float = 1.0,
    kappa: float = 0.0,
    floor: float = 1e-3,
) -> tuple[NDArray, NDArray]:
    """An elastic tendon through ``n`` guides over a block of frames (the reference; loops in Python).

    Parameters
    ----------
    t_in : ndarray, shape (T,)
        Actuator tension [N].
    d_length : ndarray, shape (T, n)
        Change of each segment's path length since the frame before [m] (ignored on resets).
    phi : ndarray, shape (T, n)
        Capstan exponent of each guide [-].
    stiffness : ndarray, shape (n,)
        ``EA / l_s`` of each segment [N/m].
    reset : ndarray of bool, shape (T,)
        Frames that start taut from the actuator: every guide on its forward-slip edge.
    loss : ndarray, shape (T, n), optional
        Tension-independent loss of each guide [N] (0 by default).
    dt : float
        Frame period [s] (viscoelastic tendon only).
    tau, kappa : float
        Relaxation time [s] and relaxing fraction [-] of the standard-linear-solid tendon;
        ``kappa = 0`` (default) is a purely elastic tendon.
    floor : float
        Lowest tension a lower edge reaches [N].

    Returns
    -------
    tension : ndarray, shape (T, n)
        Tension of segments ``1..n`` [N]; the last is the joint side.
    sigma : ndarray of int8, shape (T, n)
        Slip state of each guide.
    """
    t_in, d_length, phi = np.asarray(t_in, float), np.asarray(d_length, float), np.asarray(phi, float)
    n_frames, n = phi.shape
    k = np.asarray(stiffness, dtype=float)
    loss = np.zeros((n_frames, n)) if loss is None else np.asarray(loss, dtype=float)
    out, sigma = np.empty((n_frames, n)), np.zeros((n_frames, n), dtype=np.int8)
    tension, branch, scratch = np.zeros(n), np.zeros(n), np.empty((4, n))
    a = math.exp(-dt / tau)
    for t in range(n_frames):
        first = bool(t == 0 or reset[t])
        elastic_chain_frame(
            t_in[t], tension, branch, d_length[t], phi[t], loss[t], k, first, a, kappa, floor, *scratch, sigma[t]
        )
        out[t] = tension
    return out, sigma
