"""Compiled loops of the play-operator recurrence, with the numpy scans as fallback and reference.

The play operator (:mod:`friction_models.play_operator`) is a recurrence over time.  In
numpy it runs as a blocked prefix scan of clamp maps (:mod:`friction_models.scan`),
about twenty array passes per guide; as a plain loop compiled by numba (Lam, Pitrou &
Seibert, "Numba: a LLVM-based Python JIT compiler", LLVM-HPC 2015) it is one pass, and a
chain of guides in series is one pass for all of them (guide ``k + 1`` reads guide
``k``'s output of the same frame).  Clamping needs only comparisons, so both routes
give the same bits; the tests check that against the scans.

numba is a dependency, but the import is guarded: where it is missing (a platform
without wheels) :data:`COMPILED` is False and the same functions run the numpy scans.
Compiled code is cached on disk (``cache=True``), so only the first call on a machine
pays the compilation (about a second).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from friction_models.scan import clamp_prefix

try:  # pragma: no cover - which branch runs depends on the install
    import numba
except ImportError:  # pragma: no cover
    numba = None

#: Whether the compiled loops are in use (numba importable).
COMPILED = numba is not None


def _play_scan_loop(lo, hi, reset, start, out):  # pragma: no cover - compiled
    n, m = lo.shape
    finite = True
    for j in range(m):
        y = start[j]
        for t in range(n):
            low, high = lo[t, j], hi[t, j]
            finite &= (low - low == 0.0) & (high - high == 0.0)  # off the dependency chain
            y = low if reset[t] else min(max(y, low), high)
            out[t, j] = y
    return finite


def _play_series_loop(log_in, phi, n_pass, reset, start, final, chain, keep):  # pragma: no cover - compiled
    # Frame by frame through all guides, with min/max (no branches on stick or slip).
    n, m = log_in.shape
    state = np.zeros((phi.shape[1], m))
    finite = True
    for t in range(n):
        restart = t == 0 or reset[t]
        for j in range(m):
            x = log_in[t, j]
            finite &= x - x == 0.0
            f = start[t, j] if restart else 0.0
            for g in range(n_pass[j]):
                p = phi[t, g, j]
                finite &= p - p == 0.0
                lo = x - p
                x = lo + f * (p + p) if restart else min(max(state[g, j], lo), x + p)
                state[g, j] = x
                if keep:
                    chain[t, g, j] = x
            final[t, j] = x
    return finite


if COMPILED:
    _play_scan_loop = numba.njit(cache=True, nogil=True)(_play_scan_loop)
    _play_series_loop = numba.njit(cache=True, nogil=True)(_play_series_loop)


def _numpy_scan(lo: NDArray, hi: NDArray, reset: NDArray, start: NDArray) -> NDArray:
    """The reference route: prefix compositions of the clamps (:func:`friction_models.scan.clamp_prefix`)."""
    step_hi = np.where(reset.reshape((-1,) + (1,) * (lo.ndim - 1)), lo, hi)  # a reset is the constant map y = lo
    p_lo, p_hi = clamp_prefix(lo, step_hi)
    return np.minimum(np.maximum(start, p_lo), p_hi)


def _numpy_series(
    log_in: NDArray, phi: NDArray, n_pass: NDArray, reset: NDArray, start: NDArray, chain: NDArray | None
) -> NDArray:
    """The reference route of :func:`play_series`: one scan per guide."""
    x = np.array(log_in, dtype=float)
    first = reset.copy()
    first[0] = True
    for g in range(phi.shape[1]):
        cols = n_pass > g
        if not cols.any():
            break
        p = phi[:, g, cols]
        lo, hi = x[:, cols] - p, x[:, cols] + p
        lo = np.where(first[:, None], lo + start[:, cols] * (p + p), lo)  # a restart's state: a share of the band
        x[:, cols] = _numpy_scan(lo, hi, first, lo[0])
        if chain is not None:
            chain[:, g, cols] = x[:, cols]
    return x


def play_scan(lo: NDArray, hi: NDArray, reset: NDArray, start: NDArray) -> NDArray[np.float64]:
    """The play operator's output, one frame after another.

    Parameters
    ----------
    lo, hi : ndarray, shape (T, ...)
        Edges [ln N], ``lo <= hi`` (not checked).
    reset : ndarray of bool, shape (T,)
        Frames where the output restarts on the lower edge.
    start : ndarray, shape ``lo.shape[1:]``
        Output before frame 0 (read only if ``reset[0]`` is False).

    Returns
    -------
    ndarray, shape (T, ...)
        ``y_t = lo_t`` on a reset, else ``min(max(y_{t-1}, lo_t), hi_t)`` [ln N].  A NaN
        or infinite edge gives numpy's answer (the compiled loop hands such data to the scan).
    """
    shape = np.broadcast_shapes(np.shape(lo), np.shape(hi))
    lo, hi = np.broadcast_to(lo, shape), np.broadcast_to(hi, shape)
    reset = np.ascontiguousarray(reset, dtype=np.bool_)
    if COMPILED:
        n = shape[0]
        lo2 = np.ascontiguousarray(lo, dtype=float).reshape(n, -1)
        hi2 = np.ascontiguousarray(hi, dtype=float).reshape(n, -1)
        start2 = np.ascontiguousarray(np.broadcast_to(start, shape[1:]), dtype=float).reshape(-1)
        out = np.empty_like(lo2)
        if _play_scan_loop(lo2, hi2, reset, start2, out):
            return out.reshape(shape)
    return _numpy_scan(lo, hi, reset, start)


def play_series(
    log_in: NDArray,
    phi: NDArray,
    n_pass: NDArray,
    reset: NDArray,
    keep_chain: bool = False,
    start: NDArray | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """Nonsmooth capstan through guides in series: a play operator per guide, each fed by the last.

    Guide ``g`` of column ``j`` has the band ``[x - phi, x + phi]`` around its input ``x``
    (the tension leaving guide ``g - 1``, or ``log_in`` at the first guide), and every guide
    restarts on its forward-slip edge at a reset (and at frame 0), or, with ``start``, at the
    share ``f`` of its band: ``x - phi + 2 f phi``, the same share at every guide of the column,
    which is a state the chain can hold (each guide's output lies in its band).

    Parameters
    ----------
    log_in : ndarray, shape (T, M)
        ``ln T`` entering the first guide [ln N], one column per set and tendon.
    phi : ndarray, shape (T, K, M)
        Capstan exponent of each guide ``>= 0`` [-].
    n_pass : ndarray of int, shape (M,)
        How many guides each column passes (``<= K``).
    reset : ndarray of bool, shape (T,)
        Trajectory starts.
    keep_chain : bool
        Also return every guide's output.
    start : ndarray, shape (T, M), optional
        Share of the band ``f`` in ``[0, 1]`` each column restarts at, read at restarts only
        (default 0: forward slip, the taut start; 1 is reverse slip).

    Returns
    -------
    final : ndarray, shape (T, M)
        ``ln T`` leaving each column's last guide (``log_in`` where it passes none).
    chain : ndarray, shape (T, K, M), or None
        Output of guide ``g`` in ``chain[:, g]``, NaN beyond a column's last guide; None
        unless ``keep_chain``.
    """
    n, m = log_in.shape
    n_pass = np.minimum(np.asarray(n_pass, dtype=np.int64), phi.shape[1])
    reset = np.ascontiguousarray(reset, dtype=np.bool_)
    chain = np.full((n, phi.shape[1], m), np.nan) if keep_chain else None
    start = np.zeros((n, m)) if start is None else np.ascontiguousarray(np.broadcast_to(start, (n, m)), dtype=float)
    if COMPILED:
        final = np.empty((n, m))
        args = (np.ascontiguousarray(log_in, dtype=float), np.ascontiguousarray(phi, dtype=float), n_pass, reset)
        if _play_series_loop(*args, start, final, chain if keep_chain else np.empty((1, 1, 1)), keep_chain):
            return final, chain
    return _numpy_series(log_in, phi, n_pass, reset, start, chain), chain
