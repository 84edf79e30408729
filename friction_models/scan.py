"""Parallel prefix scans over time for the recurrences of the friction laws.

The play operator and the first-order lag are recurrences ``y_t = F_t(y_{t-1})``
whose step maps form a closed, associative family (clamps; affine maps).  Their
prefix compositions ``F_t o ... o F_1`` can therefore be built in ``ceil(log2 T)``
vectorised passes (Hillis & Steele, "Data parallel algorithms", CACM 29(12),
1986) instead of a Python loop over ``T`` frames.  Composing clamps needs only
``min``/``max``, so the clamp scan is bit-identical to the sequential loop.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def _clamp_prefix_doubling(lo: NDArray, hi: NDArray) -> tuple[NDArray, NDArray]:
    """Hillis–Steele doubling scan of clamp maps along axis 0 (``log2 T`` passes), in place."""
    n = lo.shape[0]
    d = 1
    while d < n:
        # The later map (t) applied after the earlier one (t - d): clamp the
        # earlier edges into the later interval.
        new_lo = np.clip(lo[:-d], lo[d:], hi[d:])
        new_hi = np.clip(hi[:-d], lo[d:], hi[d:])
        lo[d:] = new_lo
        hi[d:] = new_hi
        d *= 2
    return lo, hi


def clamp_prefix(lo: NDArray[np.float64], hi: NDArray[np.float64], block: int = 8) -> tuple[NDArray, NDArray]:
    """Prefix compositions of clamp maps ``y -> min(max(y, lo_t), hi_t)`` along axis 0.

    Two levels (a blocked scan): frames are grouped in blocks of ``block``;
    within a block the maps are composed one step at a time, vectorised over all
    blocks; the block totals are scanned by doubling; and each block is then
    composed with the total of the blocks before it.  About three passes over
    the data instead of ``log2 T``, and still only ``min``/``max``.

    Parameters
    ----------
    lo, hi : ndarray, shape (T, ...)
        Edges of each step's clamp, ``lo <= hi``.
    block : int
        Frames per block.

    Returns
    -------
    (lo_p, hi_p) : ndarrays, shape (T, ...)
        Edges of ``F_t o ... o F_0``: the output at step ``t`` from any earlier
        state ``y`` is ``clip(y, lo_p[t], hi_p[t])``.
    """
    lo = np.array(lo, dtype=float, copy=True)
    hi = np.array(hi, dtype=float, copy=True)
    n = lo.shape[0]
    if n <= 2 * block:
        return _clamp_prefix_doubling(lo, hi)
    nb = -(-n // block)
    pad = nb * block - n
    if pad:  # identity maps (clamp to the whole line) at the end change nothing before them
        tail = (pad,) + lo.shape[1:]
        lo = np.concatenate([lo, np.full(tail, -np.inf)])
        hi = np.concatenate([hi, np.full(tail, np.inf)])
    L = lo.reshape((nb, block) + lo.shape[1:])
    H = hi.reshape((nb, block) + hi.shape[1:])
    for b in range(1, block):  # within each block, step by step (clip written as min/max into place)
        new_lo = np.minimum(np.maximum(L[:, b - 1], L[:, b]), H[:, b])
        np.minimum(np.maximum(H[:, b - 1], L[:, b]), H[:, b], out=H[:, b])
        L[:, b] = new_lo
    tot_lo, tot_hi = _clamp_prefix_doubling(L[:, -1].copy(), H[:, -1].copy())  # whole blocks
    before_lo = np.expand_dims(tot_lo[:-1], 1)
    before_hi = np.expand_dims(tot_hi[:-1], 1)
    new_lo = np.clip(before_lo, L[1:], H[1:])
    H[1:] = np.clip(before_hi, L[1:], H[1:])
    L[1:] = new_lo
    return lo[:n], hi[:n]


def affine_prefix(a: NDArray[np.float64], b: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    """Prefix compositions of affine maps ``z -> a_t z + b_t`` along axis 0.

    Parameters
    ----------
    a, b : ndarray, shape (T, ...)
        Slopes and offsets of each step.

    Returns
    -------
    (a_p, b_p) : ndarrays, shape (T, ...)
        ``F_t o ... o F_0`` is ``z -> a_p[t] z + b_p[t]``.
    """
    a = np.array(a, dtype=float, copy=True)
    b = np.array(b, dtype=float, copy=True)
    n = a.shape[0]
    d = 1
    while d < n:
        new_b = a[d:] * b[:-d] + b[d:]
        new_a = a[d:] * a[:-d]
        a[d:] = new_a
        b[d:] = new_b
        d *= 2
    return a, b
