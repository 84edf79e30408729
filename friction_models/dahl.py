"""The Dahl smooth edge: friction that builds up over a travel instead of at once.

Dahl's model of solid friction (P. R. Dahl, "Solid friction damping of mechanical vibrations",
AIAA Journal 14(12):1675-1682, 1976) with exponent ``i = 1``,
``dF/dx = sigma_0 (1 - F sgn(dx) / F_c)``, makes the friction force approach its sliding value
``F_c sgn(dx)`` exponentially in the travel ``x``, with the characteristic length
``F_c / sigma_0``: a rate-independent first-order lag in travel, not in time. In a tendon the
length is set by its compliance: after a reversal the tendon stretches elastically
(pre-sliding) before the new slip direction is established.

:func:`travel_lag` applies it to any target: the output approaches the target (a slip edge,
or a play operator's output) by ``1 - exp(-|dx| / length)`` of the way per step. It is an
affine recurrence, run as a prefix scan (vectorised over time).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from friction_models.scan import affine_prefix

__all__ = ["travel_lag"]


def travel_lag(target: ArrayLike, travel: ArrayLike, length: float, reset: ArrayLike | None = None) -> NDArray:
    """``y_t = target_t + (y_{t-1} - target_t) exp(-|x_t - x_{t-1}| / length)``.

    Parameters
    ----------
    target : array_like, shape (T, ...)
        What the output approaches (any unit), time on axis 0.
    travel : array_like, shape (T,) or (T, ...)
        The travel ``x`` the lag is measured in (e.g. the input-side position [rad]).
    length : float
        Characteristic travel, in ``travel``'s unit, > 0; 0 gives ``y = target``.
    reset : array_like of bool, shape (T,), optional
        Trajectory starts: the output starts at the target there (frame 0 always does).

    Returns
    -------
    ndarray, shape of ``target``
    """
    target = np.asarray(target, dtype=float)
    x = np.asarray(travel, dtype=float)
    n = target.shape[0]
    step = np.zeros_like(x)
    step[1:] = np.abs(np.diff(x, axis=0))
    if length <= 0:
        return target.copy()
    a = np.exp(-step / float(length))
    starts = np.zeros(n, dtype=bool) if reset is None else np.asarray(reset, dtype=bool).copy()
    starts[0] = True
    a = np.where(starts.reshape((-1,) + (1,) * (a.ndim - 1)), 0.0, a)
    a = np.broadcast_to(a.reshape(a.shape + (1,) * (target.ndim - a.ndim)), target.shape)
    _, y = affine_prefix(a, (1.0 - a) * target)
    return y
