"""Tension loss from the bending stiffness of the tendon."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def bending_loss(alpha: ArrayLike, dT_b: float) -> NDArray[np.float64]:
    """Tension-independent loss ``dT_b * alpha`` [N] of a stiff tendon bent by ``alpha``.

    Bending a tendon of flexural rigidity ``EI`` round a guide costs work that
    does not scale with the tension, so to first order it removes a constant
    force per radian of wrap (the rope "bending resistance" of Feyrer, "Wire
    Ropes", Springer 2007, §3.3; DESIGN §5).  Its log-ratio signature is
    ``-dT_b alpha / T``, i.e. it scales like 1/T.

    Parameters
    ----------
    alpha : array_like
        Wrap angle [rad].
    dT_b : float
        Loss per radian of wrap [N/rad], ``>= 0``.
    """
    if dT_b < 0:
        raise ValueError("dT_b must be non-negative (N/rad)")
    return dT_b * np.asarray(alpha, dtype=float)
