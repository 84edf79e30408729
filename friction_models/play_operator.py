"""The log-domain play operator: stick/slip hysteresis of the nonsmooth capstan.

A tendon passage with Coulomb friction transmits any output tension within the
capstan cone ``T_in e^{-phi} <= T_out <= T_in e^{+phi}``; inside it the tendon
sticks and the output keeps its previous value, at the lower edge it slides
forward (pulled towards the joint), at the upper edge backwards.  In the log
domain this is the play (backlash) operator

    ln T_out(t) = clamp(ln T_out(t-1), ln T_in(t) - phi(t), ln T_in(t) + phi(t)),

the nonsmooth capstan of the paper's Section III-B and its ref. [12] (the
stick bounds of Eq. (6) with sigma in {-1, 0, +1}); the play operator itself is
Krasnosel'skii & Pokrovskii, "Systems with Hysteresis", Springer 1989.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from friction_models.kernels import play_scan


@dataclass(frozen=True)
class PlayResult:
    """Output of :func:`play_operator`.

    Attributes
    ----------
    log_out : ndarray, shape (T, ...)
        ``ln T_out`` [ln N].
    sigma : ndarray of int8, shape (T, ...)
        +1 forward slip (output on the lower edge), -1 reverse slip (upper
        edge), 0 stick (strictly inside the cone).  Where the cone has zero
        width (``phi = 0``) the tendon is reported as forward slip.
    """

    log_out: NDArray[np.float64]
    sigma: NDArray[np.int8]


def _as_reset(reset: ArrayLike | None, n: int) -> NDArray[np.bool_]:
    if reset is None:
        out = np.zeros(n, dtype=bool)
    else:
        out = np.asarray(reset, dtype=bool).copy()
        if out.shape != (n,):
            raise ValueError(f"reset must have shape ({n},), got {out.shape}")
    out[0] = True
    return out


def slip_state(log_out: ArrayLike, lo: ArrayLike, hi: ArrayLike) -> NDArray[np.int8]:
    """Slip state sigma of a play-operator output relative to its edges.

    Parameters
    ----------
    log_out, lo, hi : array_like
        Output and cone edges, all in the same (log) units.

    Returns
    -------
    ndarray of int8
        +1 on the lower edge, -1 on the upper edge, 0 strictly inside.
    """
    y = np.asarray(log_out)
    sigma = np.zeros(np.broadcast_shapes(y.shape, np.shape(lo), np.shape(hi)), dtype=np.int8)
    sigma[y >= hi] = -1
    sigma[y <= lo] = 1  # on a zero-width cone the lower edge wins: forward slip
    return sigma


def play_operator_edges(
    lo: ArrayLike, hi: ArrayLike, reset: ArrayLike | None = None, y0: ArrayLike | None = None
) -> PlayResult:
    """Play operator with explicit edges ``lo(t) <= hi(t)`` (any units).

    Parameters
    ----------
    lo, hi : array_like, shape (T, ...)
        Lower (forward-slip) and upper (reverse-slip) edge per frame.
    reset : array_like of bool, shape (T,), optional
        True on the first frame of each trajectory.  There the tendon has just
        been pulled taut, so the output starts on the forward-slip edge
        (``y = lo``).  Frame 0 is always a reset unless ``y0`` is given.
    y0 : array_like, optional
        Output before frame 0; if given, frame 0 is not forced to a reset.

    Returns
    -------
    PlayResult
    """
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    lo, hi = np.broadcast_arrays(lo, hi)
    if lo.ndim == 0 or lo.shape[0] == 0:
        raise ValueError("lo and hi need a leading time axis with at least one frame")
    if np.any(hi < lo):
        raise ValueError("play operator needs lo <= hi at every frame (phi >= 0)")
    y = play_output(lo, hi, _as_reset(reset, lo.shape[0]) if y0 is None else _reset_with_y0(reset, lo.shape[0]), y0)
    return PlayResult(log_out=y, sigma=slip_state(y, lo, hi))


def _reset_with_y0(reset: ArrayLike | None, n: int) -> NDArray[np.bool_]:
    r = np.zeros(n, dtype=bool) if reset is None else np.asarray(reset, dtype=bool).copy()
    if r.shape != (n,):
        raise ValueError(f"reset must have shape ({n},), got {r.shape}")
    return r


def play_output(lo: NDArray, hi: NDArray, reset: NDArray, y0: ArrayLike | None = None) -> NDArray[np.float64]:
    """The play operator's output alone, without checks: the inner loop of calibration.

    Compiled where numba is installed, else the clamp scan (:mod:`friction_models.kernels`).

    Parameters
    ----------
    lo, hi : ndarray, shape (T, ...)
        Edges, ``lo <= hi`` (not checked).
    reset : ndarray of bool, shape (T,)
        Trajectory starts; ``reset[0]`` must be True unless ``y0`` is given.
    y0 : array_like, optional
        Output before frame 0.
    """
    start = lo[0] if y0 is None else np.broadcast_to(np.asarray(y0, dtype=float), lo.shape[1:])
    return play_scan(lo, hi, np.asarray(reset, dtype=bool), start)


def play_operator(
    log_in: ArrayLike, phi: ArrayLike, reset: ArrayLike | None = None, y0: ArrayLike | None = None
) -> PlayResult:
    """Nonsmooth capstan through one guide in the log domain.

    ``ln T_out(t) = clamp(ln T_out(t-1), ln T_in(t) - phi(t), ln T_in(t) + phi(t))``.

    Parameters
    ----------
    log_in : array_like, shape (T, ...)
        ``ln T_in`` [ln N], time on axis 0.
    phi : array_like
        Capstan exponent ``>= 0`` [-], broadcast against ``log_in``.
    reset, y0 :
        See :func:`play_operator_edges`.

    Returns
    -------
    PlayResult
        Every ratio ``T_out / T_in`` lies in ``[exp(-phi), exp(+phi)]``.
    """
    x = np.asarray(log_in, dtype=float)
    p = np.asarray(phi, dtype=float)
    if np.any(p < 0):
        raise ValueError("phi must be non-negative")
    return play_operator_edges(x - p, x + p, reset=reset, y0=y0)
