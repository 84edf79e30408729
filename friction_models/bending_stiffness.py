"""Tension loss from the bending stiffness of the tendon."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def bending_loss(alpha: ArrayLike, dT_b: float) -> NDArray[np.float64]:
    """Tension-independent loss ``dT_b * alpha`` [N] of a stiff tendon bent by ``alpha``.

    Bending a tendon of flexural rigidity ``EI`` round a guide costs work that
    does not scale with the tension, so to first order it removes a constant
    force per radian of wrap (the rope "bending resistance" of Feyrer, "Wire
    Ropes", Springer 2007, §3.3; :doc:`/guide/simulator`).  Its log-ratio signature is
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


#: Smallest tension [N] a bending-stiffness loss may leave; the taut regime
#: (paper §III-D) is far above it, so it only keeps logarithms finite.
SLACK_FLOOR_N = 1e-3


def edges_with_loss(lo: ArrayLike, hi: ArrayLike, loss: ArrayLike) -> tuple[NDArray, NDArray]:
    """Slip edges of a guide in the log domain with a tension-independent loss.

    A guide with friction exponent ``phi`` and a bending loss ``L`` [N] passes
    ``T_out = T_in exp(-phi) - L`` in forward slip and ``T_in exp(+phi) + L`` in
    reverse slip (the loss always opposes the motion).  Given the capstan edges
    ``lo = ln T_in - phi`` and ``hi = ln T_in + phi``, the edges become
    ``ln(exp(lo) - L)`` (floored at :data:`SLACK_FLOOR_N`) and ``ln(exp(hi) + L)``.

    Parameters
    ----------
    lo, hi : array_like
        Capstan slip edges [ln N].
    loss : array_like
        Loss per guide [N], ``>= 0``, broadcast against the edges.
    """
    lo = np.log(np.maximum(np.exp(lo) - loss, SLACK_FLOOR_N))
    hi = np.log(np.exp(hi) + loss)
    return lo, hi
