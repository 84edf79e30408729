"""Viscoelastic lag of transmitted tension (a standard linear solid)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from friction_models.scan import affine_prefix


def viscoelastic_lag(
    tension: ArrayLike,
    dt: float,
    tau_v: float,
    kappa: float,
    reset: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Relax a transmitted tension towards its quasi-static value.

    A Zener (standard linear solid) element in series with the passage: a
    fraction ``1 - kappa`` of a tension change arrives at once, the rest relaxes
    in with time constant ``tau_v`` (Findley, Lai & Onaran, "Creep and Relaxation
    of Nonlinear Viscoelastic Materials", 1976, ch. 5)::

        z(t) = a z(t-1) + (1 - a) T(t),   a = exp(-dt / tau_v)   (exact ZOH step)
        T_out(t) = (1 - kappa) T(t) + kappa z(t)

    Parameters
    ----------
    tension : array_like, shape (T, ...)
        Quasi-static tension [N], time on axis 0.
    dt : float
        Sample period [s].
    tau_v : float
        Relaxation time constant [s], ``> 0``.
    kappa : float
        Relaxing fraction in ``[0, 1]``.
    reset : array_like of bool, shape (T,), optional
        True at the first frame of each trajectory, where the element starts
        relaxed (``z = T``).  Frame 0 always is.

    Returns
    -------
    ndarray, shape (T, ...)
        Lagged tension [N].
    """
    if dt <= 0 or tau_v <= 0:
        raise ValueError("dt and tau_v must be positive times in s")
    if not 0.0 <= kappa <= 1.0:
        raise ValueError("kappa must lie in [0, 1]")
    x = np.asarray(tension, dtype=float)
    n = x.shape[0]
    r = np.zeros(n, dtype=bool) if reset is None else np.asarray(reset, dtype=bool).copy()
    r[0] = True
    a_step = np.exp(-dt / tau_v)
    a = np.full(x.shape, a_step)
    b = (1.0 - a_step) * x
    a[r] = 0.0
    b[r] = x[r]
    _, z = affine_prefix(a, b)  # z(-1) is irrelevant: frame 0 is a reset
    return (1.0 - kappa) * x + kappa * z
