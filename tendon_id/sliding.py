"""How fast a tendon slides through its guides as the joints bend (:doc:`/guide/geometry`).

A tendon anchored at joint ``j`` slides through guide ``k`` as fast as its path beyond the guide
changes length; bending joint ``m`` by ``b_m(psi)`` shortens the path across it by ``r b_m``
(small angles, hole radius ``r``; :func:`tendon_id.geometry.projected_bend`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tendon_id.geometry import RobotGeometry, crossing_length, joint_rotation, tendon_azimuths

__all__ = [
    "backward_rate",
    "guide_sliding_distance",
    "guide_sliding_speed",
    "path_rate_at",
    "segment_length",
    "segment_path_lengths",
    "sliding_speed",
    "sliding_speed_at",
]


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
    out = np.zeros((theta.shape[0], n - 1, n, psi.shape[-1]))
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


def guide_sliding_distance(theta: NDArray, reset: NDArray, geometry: RobotGeometry, dt: float) -> NDArray[np.float64]:
    """Cumulative sliding distance through each guide [m], shape (T, N-1).

    A tendon of set ``j`` slides through guide ``k < j`` as fast as its path beyond the guide
    changes length (:func:`sliding_speed`).  The guide's speed is the mean
    of that over the ``3 (N - k)`` tendons passing it; its distance at frame ``t`` is the sum of
    those speeds times ``dt`` over frames ``1..t`` (rectangle rule: the backward-difference speed
    of frame ``t`` is the mean speed over the period ending there).  The speed is zero at a reset,
    where the pose jumps rather than moves.

    Parameters
    ----------
    theta : ndarray, shape (T, N, 2)
        True joint angles of the whole session [rad].
    reset : ndarray of bool, shape (T,)
        True where the session restarts (no motion into that frame).
    geometry : RobotGeometry
    dt : float
        Sample period [s].
    """
    theta = np.asarray(theta, dtype=float)
    n = geometry.n_modules
    if theta.ndim != 3 or theta.shape[1:] != (n, 2):
        raise ValueError(f"theta must have shape (T, {n}, 2), got {theta.shape}")
    reset = np.asarray(reset, dtype=bool)
    if reset.shape != theta.shape[:1]:
        raise ValueError(f"reset needs one flag per frame, shape ({theta.shape[0]},), got {reset.shape}")
    speed = guide_sliding_speed(backward_rate(np.cumsum(theta, axis=1), reset, dt), geometry)
    return np.cumsum(speed, axis=0) * dt


def guide_sliding_speed(cum_rate: NDArray, geometry: RobotGeometry) -> NDArray[np.float64]:
    """Mean sliding speed [m/s] of the tendons through each guide, shape (T, N-1).

    Parameters
    ----------
    cum_rate : ndarray, shape (T, N, 2)
        Rate of the running sum of the joint angles over the joints [rad/s]
        (:func:`backward_rate` of ``cumsum(theta, axis=1)``); ``T`` may be
        frames or, for one step of the closed loop, a batch of robots.
    geometry : RobotGeometry
    """
    n = geometry.n_modules
    psi = tendon_azimuths(geometry)
    speed = np.empty((cum_rate.shape[0], n - 1))
    for g in range(n - 1):  # guide by guide: memory stays at (T, sets, 3)
        speed[:, g] = sliding_speed_at(cum_rate, g, psi, geometry.hole_radius).mean(axis=(1, 2))
    return speed


def segment_path_lengths(theta: NDArray, geometry: RobotGeometry) -> NDArray:
    """Changing part of each tendon segment's path [m], shape (T, N-1, N, 3).

    ``[t, g, j, i]``: the straight segment across joint ``g + 2`` (1-based) of tendon ``i`` of set
    ``j``, which lies between guides ``g + 1`` and ``g + 2``; the rest of the segment runs along a
    link and does not change length.
    """
    psi = tendon_azimuths(geometry)
    ux, uy = geometry.hole_radius * np.cos(psi), geometry.hole_radius * np.sin(psi)
    R = joint_rotation(np.asarray(theta, dtype=float)[:, 1:])  # joints 2..N
    return crossing_length(R[:, :, None, None], ux, uy, 0.5 * geometry.joint_gap)


def segment_length(geometry) -> float:
    """Unstretched length [m] of a tendon segment between two guides: one module's pitch.

    The friction of a guide is lumped at its link (:doc:`/guide/simulator`), so the elastic
    segment between guides ``k`` and ``k + 1`` runs from the middle of link ``k`` to the middle
    of link ``k + 1``: a link and a joint gap.  The last segment, to the anchor, is taken as long.
    """
    return float(geometry.link_length + geometry.joint_gap)
