"""A smooth edge of the stick/slip band: a sum of play operators of several widths.

A tendon's wrap over a guide touches it along a contact, not at a point, and the tendon is
compliant between the points of contact.  After a reversal of the driving tension, the
contact does not slip all at once: the slip zone grows along the contact as the driving
tension changes, each element of it slipping once the tension change that reaches it exceeds
what its friction holds.  The generalised Maxwell-slip model (Lampaert, Al-Bender & Swevers,
"A generalized Maxwell-slip friction model appropriate for control purposes", IEEE PhysCon
2003; Al-Bender, Lampaert & Swevers, "The generalized Maxwell-slip model: a novel model for
friction simulation and compensation", IEEE Trans. Autom. Control 50(11):1883-1887, 2005)
writes such a contact as ``K`` elasto-slide elements in parallel; for a rate-independent
element it is the Prandtl-Ishlinskii sum of play operators of several widths
(Krasnosel'skii & Pokrovskii, "Systems with Hysteresis", Springer 1989; Brokate & Sprekels,
"Hysteresis and Phase Transitions", Springer 1996, ch. 2).

Here the elements share the band's centre ``c = (lo + hi) / 2`` and their half-widths are the
midpoints of ``K`` equal parts of ``(1 - w, 1 + w)`` times the band's half-width ``h = (hi - lo) / 2``::

    h_k = h (1 + w u_k),   u_k = (2k + 1) / K - 1,  k = 0 .. K - 1      (mean of h_k = h)
    y   = (1 / K) sum_k play(c - h_k, c + h_k)

The spread ``w`` in ``[0, 1]`` is the edge's width as a fraction of the band: after a full
reversal the output holds (stick) until the driving side has crossed about ``1 - w`` of the
band (``1 - w (1 - 1/K)`` exactly), then joins the new edge gradually, and slides on it once
about ``1 + w`` of the band is crossed.
``w = 0`` is the sharp play operator.  Under sustained slip every element is on its edge, so
the output is on the band's edge (Coulomb friction) and never outside the band.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from friction_models.play_operator import PlayResult, play_operator_edges, play_output

__all__ = ["ELEMENTS", "element_factors", "maxwell_slip", "maxwell_slip_output"]

#: Elements of the contact (play operators) by default: the edge is piecewise linear with this
#: many slopes. On the bench that anchors the simulator's ``stick_slip.edge_width``, 4, 8 and 16
#: elements fitted the same spread to within 0.004 (0.266, 0.269, 0.270 with stick/slip alone).
ELEMENTS = 8


def element_factors(width: float, elements: int = ELEMENTS) -> NDArray[np.float64]:
    """Each element's half-width over the band's, ``1 + w u_k``, shape (K,) (their mean is 1)."""
    u = (2.0 * np.arange(elements) + 1.0) / elements - 1.0
    return 1.0 + float(width) * u


def maxwell_slip_output(
    lo: NDArray,
    hi: NDArray,
    reset: NDArray,
    width: float,
    elements: int = ELEMENTS,
    sliding: NDArray | None = None,
    y0: NDArray | None = None,
    with_state: bool = False,
):
    """The smooth-edged output and its slip state, without checks: the inner loop of a simulation or a fit.

    Parameters
    ----------
    lo, hi : ndarray, shape (T, ...)
        The band's edges per frame, ``lo <= hi`` (any units; the log tension [ln N] in a guide).
    reset : ndarray of bool, shape (T,)
        Trajectory starts (``reset[0]`` True): every element starts on its forward-slip edge,
        so the output starts on ``lo``, as the sharp play operator's does.
    width : float
        Spread ``w`` of the elements' half-widths, a fraction of the band's, in [0, 1].
    elements : int
        ``K``, the number of elements.
    sliding : ndarray, shape (T, ...), optional
        +1 where the tendon slides forward through the guide, -1 backward, 0 otherwise: a
        sliding contact puts every element on the edge of its direction of motion (the
        ``"motion"`` driver of the simulator).
    y0 : ndarray, shape (..., K), optional
        The elements' outputs before frame 0 (a previous call's ``state``), read where
        ``reset[0]`` is False: a long log evaluated in windows continues exactly.
    with_state : bool
        Also return the elements' outputs at the last frame.

    Returns
    -------
    (y, sigma) or (y, sigma, state)
        ``y`` within ``[lo, hi]``; ``sigma`` +1 (-1) where more than half the elements slip
        forward (backward), else 0 (the contact mostly sticks); ``state``, shape (..., K).
    """
    c = 0.5 * (lo + hi)[..., None]
    hk = 0.5 * (hi - lo)[..., None] * element_factors(width, elements)
    lo_k, hi_k = c - hk, c + hk
    if sliding is None:
        y_k = play_output(lo_k, hi_k, reset, y0)
    else:
        s = np.asarray(sliding)[..., None]
        y_k = play_output(np.where(s < 0, hi_k, lo_k), np.where(s > 0, lo_k, hi_k), reset, y0)
    # The mean of elements on their edges is the band's edge up to rounding: clip it into the band.
    y = np.clip(y_k.mean(axis=-1), lo, hi)
    half = elements / 2.0
    forward = np.count_nonzero(y_k <= lo_k, axis=-1) > half
    backward = np.count_nonzero(y_k >= hi_k, axis=-1) > half
    sigma = forward.astype(np.int8) - backward.astype(np.int8)
    return (y, sigma, y_k[-1].copy()) if with_state else (y, sigma)


def maxwell_slip(
    lo: ArrayLike, hi: ArrayLike, width: float, reset: ArrayLike | None = None, elements: int = ELEMENTS
) -> PlayResult:
    """Play operator with a smooth edge: the mean of ``K`` play operators of spread half-widths.

    Parameters
    ----------
    lo, hi : array_like, shape (T, ...)
        Lower (forward-slip) and upper (reverse-slip) edge per frame, ``lo <= hi``.
    width : float
        Spread ``w`` of the elements' half-widths as a fraction of the band's, in [0, 1];
        0 is :func:`~friction_models.play_operator.play_operator_edges` exactly.
    reset : array_like of bool, shape (T,), optional
        Trajectory starts (frame 0 always is one).
    elements : int
        Number of elements ``K`` >= 1.

    Returns
    -------
    PlayResult
        ``log_out`` within ``[lo, hi]``; ``sigma`` as :func:`maxwell_slip_output` says.
    """
    if not 0.0 <= float(width) <= 1.0:
        raise ValueError(f"width must lie in [0, 1] (a fraction of the band), got {width}")
    if int(elements) < 1:
        raise ValueError(f"elements must be >= 1, got {elements}")
    if width == 0:
        return play_operator_edges(lo, hi, reset)
    lo, hi = np.broadcast_arrays(np.asarray(lo, dtype=float), np.asarray(hi, dtype=float))
    if lo.ndim == 0 or lo.shape[0] == 0:
        raise ValueError("lo and hi need a leading time axis with at least one frame")
    if np.any(hi < lo):
        raise ValueError("the band needs lo <= hi at every frame")
    r = np.zeros(lo.shape[0], dtype=bool) if reset is None else np.asarray(reset, dtype=bool).copy()
    if r.shape != (lo.shape[0],):
        raise ValueError(f"reset must have shape ({lo.shape[0]},), got {r.shape}")
    r[0] = True
    y, sigma = maxwell_slip_output(lo, hi, r, float(width), int(elements))
    return PlayResult(log_out=y, sigma=sigma)
