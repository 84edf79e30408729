"""Friction that runs in and wears over a session, per guide from its sliding distance (:doc:`/guide/simulator`).

The effect ``friction_drift`` (:class:`~tendon_id.sim.effects.FrictionDrift`) makes each guide's friction
a function of how far the tendons have slid through it so far
(:func:`friction_models.run_in_wear_factor`).  :func:`drift_factors` gives that multiplier per frame
and guide, from the kinematics of the whole session (unlogged frames included), for the
transmission to use as a time-varying wear factor.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from friction_models import run_in_wear_factor
from tendon_id.geometry import RobotGeometry, tendon_azimuths
from tendon_id.sim.sensor_effects import FrictionDrift
from tendon_id.sliding import backward_rate, sliding_speed_at

__all__ = ["drift_at", "drift_factors", "guide_sliding_distance", "guide_sliding_speed"]


def guide_sliding_distance(theta: NDArray, reset: NDArray, geometry: RobotGeometry, dt: float) -> NDArray[np.float64]:
    """Cumulative sliding distance through each guide [m], shape (T, N-1).

    A tendon of set ``j`` slides through guide ``k < j`` as fast as its path beyond the guide
    changes length (:func:`tendon_id.sliding.sliding_speed`).  The guide's speed is the mean
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
        (:func:`tendon_id.sliding.backward_rate` of ``cumsum(theta, axis=1)``); ``T`` may be
        frames or, for one step of the closed loop, a batch of robots.
    geometry : RobotGeometry
    """
    n = geometry.n_modules
    psi = tendon_azimuths(geometry)
    speed = np.empty((cum_rate.shape[0], n - 1))
    for g in range(n - 1):  # guide by guide: memory stays at (T, sets, 3)
        speed[:, g] = sliding_speed_at(cum_rate, g, psi, geometry.hole_radius).mean(axis=(1, 2))
    return speed


def drift_at(slid: NDArray, effect: FrictionDrift) -> NDArray[np.float64]:
    """Friction multiplier [-] of guides that have slid ``slid`` [m] in this session (before: ``prior_sliding_m``)."""
    return run_in_wear_factor(
        slid + effect.prior_sliding_m, effect.run_in_drop, effect.run_in_length_m, effect.wear_rate_per_m
    )


def drift_factors(
    theta: NDArray, reset: NDArray, geometry: RobotGeometry, effect: FrictionDrift, dt: float
) -> NDArray[np.float64]:
    """Friction multiplier of each guide at each frame [-], shape (T, N-1).

    ``w_k(t) = run_in_wear_factor(s0 + s_k(t), ...)`` with ``s_k`` the guide's sliding distance
    so far (:func:`guide_sliding_distance`) and ``s0 = effect.prior_sliding_m`` what the guides
    had slid before the session.  It multiplies the capstan exponent at guide ``k``, like the
    static factor of ``guide_wear``.

    Parameters
    ----------
    theta : ndarray, shape (T, N, 2)
        True joint angles of the whole session [rad], unlogged frames included.
    reset : ndarray of bool, shape (T,)
        True where the session restarts.
    geometry : RobotGeometry
    effect : FrictionDrift
        The effect's settings.
    dt : float
        Sample period [s].
    """
    return drift_at(guide_sliding_distance(theta, reset, geometry, dt), effect)
