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


def clamp_prefix(lo: NDArray[np.float64], hi: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    """Prefix compositions of clamp maps ``y -> min(max(y, lo_t), hi_t)`` along axis 0.

    Parameters
    ----------
    lo, hi : ndarray, shape (T, ...)
        Edges of each step's clamp, ``lo <= hi``.

    Returns
    -------
    (lo_p, hi_p) : ndarrays, shape (T, ...)
        Edges of ``F_t o ... o F_0``: the output at step ``t`` from any earlier
        state ``y`` is ``clip(y, lo_p[t], hi_p[t])``.
    """
    lo = np.array(lo, dtype=float, copy=True)
    hi = np.array(hi, dtype=float, copy=True)
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
