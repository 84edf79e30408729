"""Per-guide friction multipliers for worn or damaged guides."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray


def guide_wear_factors(n_guides: int, worn: Mapping[int, float]) -> NDArray[np.float64]:
    """Friction multiplier ``w_k`` per guide (:doc:`/guide/simulator` ``guide_wear``).

    Wear roughens a guide's bore and raises its friction coefficient; here it
    multiplies the capstan exponent, ``phi_k = w_k mu(alpha) alpha``.  This breaks
    the paper's tribological-homogeneity assumption (Section III-D).

    Parameters
    ----------
    n_guides : int
        Number of guides ``N - 1``.
    worn : mapping of int to float
        1-based guide index ``k`` to its multiplier (``> 0``).

    Returns
    -------
    ndarray, shape (n_guides,)
        1.0 except at the worn guides.
    """
    w = np.ones(n_guides)
    for k, factor in worn.items():
        if not 1 <= int(k) <= n_guides:
            raise ValueError(f"worn guide {k} is outside 1..{n_guides}")
        if factor <= 0:
            raise ValueError(f"wear factor of guide {k} must be positive, got {factor}")
        w[int(k) - 1] = float(factor)
    return w
