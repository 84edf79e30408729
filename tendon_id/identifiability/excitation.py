"""Excitation coverage per guide: what range of wraps each guide saw, and how independently.

A guide whose wrap never changes, or changes in lock-step with a neighbour, cannot
have its own friction law told apart from the others' from terminal data alone.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def _corr(a: NDArray, b: NDArray) -> float | None:
    if np.std(a) == 0 or np.std(b) == 0:
        return None
    return float(np.corrcoef(a, b)[0, 1])


def excitation(wrap: NDArray, gate: NDArray | None = None) -> list[dict]:
    """Coverage of each guide's wrap.

    Parameters
    ----------
    wrap : ndarray, shape (T, K)
        Backbone wrap per guide [rad].
    gate : ndarray, shape (T, K), optional
        Contact gate (0..1); the share of frames in contact is reported when given.

    Returns
    -------
    list of dict, one per guide
        ``guide`` (1-based), ``min_deg``, ``max_deg``, ``p5_deg``, ``p95_deg``, ``sd_deg``,
        ``distinct`` (distinct readings), ``corr_prev`` / ``corr_next`` (Pearson correlation
        with the neighbouring guides' wraps; None when either is constant) and
        ``in_contact`` (share of frames with gate above 0.5, or None).
    """
    wrap = np.asarray(wrap, dtype=float)
    k = wrap.shape[1]
    deg = np.rad2deg(wrap)
    out = []
    for g in range(k):
        w = deg[:, g]
        out.append(
            {
                "guide": g + 1,
                "min_deg": float(w.min()),
                "max_deg": float(w.max()),
                "p5_deg": float(np.percentile(w, 5)),
                "p95_deg": float(np.percentile(w, 95)),
                "sd_deg": float(w.std()),
                "distinct": int(len(np.unique(w))),
                "corr_prev": _corr(w, deg[:, g - 1]) if g > 0 else None,
                "corr_next": _corr(w, deg[:, g + 1]) if g < k - 1 else None,
                "in_contact": None if gate is None else float(np.mean(gate[:, g] > 0.5)),
            }
        )
    return out
