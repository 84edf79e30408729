"""How fast a tendon slides through its guides as the joints bend (:doc:`/guide/geometry`).

A tendon anchored at joint ``j`` slides through guide ``k`` as fast as its path beyond the guide
changes length; bending joint ``m`` by ``b_m(psi)`` shortens the path across it by ``r b_m``
(small angles, hole radius ``r``; :func:`tendon_id.geometry.projected_bend`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tendon_id.geometry import RobotGeometry, tendon_azimuths

__all__ = ["backward_rate", "path_rate_at", "sliding_speed", "sliding_speed_at"]


def backward_rate(x: NDArray, reset: NDArray, dt: float) -> NDArray:
    """Backward-difference time derivative along axis 0 [unit/s], zero on each trajectory's first frame."""
    rate = np.zeros_like(x)
    rate[1:] = (x[1:] - x[:-1]) / dt
    rate[reset] = 0.0
    return rate


def sliding_speed(theta: NDArray, geometry: RobotGeometry, reset: NDArray, dt: float) -> NDArray:
    """Speed [m/s] at which tendon ``i`` of set ``j`` slides through guide ``k``.

    The tendon is anchored at joint ``j``, so it slides through guide ``k`` as
    fast as its path beyond guide ``k`` changes length; across joint ``m`` that
    length changes by ``-r b_m(psi)`` (small angles, hole radius ``r``).

    Returns
    -------
    ndarray, shape (T, N-1, N, 3)
        Zero where set ``j`` does not pass guide ``k``.
    """
    n = geometry.n_modules
    psi = tendon_azimuths(geometry)
    cum_rate = backward_rate(np.cumsum(theta, axis=1), reset, dt)
    out = np.zeros((theta.shape[0], n - 1, n, 3))
    for g in range(n - 1):
        out[:, g, g + 1 :] = sliding_speed_at(cum_rate, g, psi, geometry.hole_radius)
    return out


def path_rate_at(cum_rate: NDArray, g: int, psi: NDArray, hole_radius: float) -> NDArray:
    """Signed rate [m/s] at which the path beyond guide index ``g`` lengthens, shape (T, N-g-1, 3).

    Bending joint ``m`` by ``b_m(psi)`` shortens the tendon's path across it by ``r b_m``
    (small angles, hole radius ``r``), and the projected bend is linear in theta, so the
    joint-angle rates beyond guide ``k`` are summed first:
    ``sum_{m=k+1..j} theta_m = C_j - C_k`` with ``C`` the running sum over joints.
    Positive: the tendon is drawn distally through the guide (reverse slip); negative:
    towards the actuator (forward slip).
    """
    beyond = cum_rate[:, g + 1 :] - cum_rate[:, g, None]  # sum of theta_m rates, m = k+1..j
    psi_on = psi[g + 1 :]
    return -hole_radius * (beyond[..., 0, None] * np.cos(psi_on) + beyond[..., 1, None] * np.sin(psi_on))


def sliding_speed_at(cum_rate: NDArray, g: int, psi: NDArray, hole_radius: float) -> NDArray:
    """:func:`sliding_speed` for one guide (index ``g``) and the sets beyond it, shape (T, N-g-1, 3)."""
    return np.abs(path_rate_at(cum_rate, g, psi, hole_radius))
