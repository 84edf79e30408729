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
from tendon_id.geometry import RobotGeometry
from tendon_id.sim.sensor_effects import FrictionDrift
from tendon_id.sliding import guide_sliding_distance

__all__ = ["drift_at", "drift_factors"]


def drift_at(slid: NDArray, effect: FrictionDrift) -> NDArray[np.float64]:
    """Friction multiplier [-] of guides that have slid ``slid`` [m] in this session (before: ``prior_sliding_m``)."""
    return run_in_wear_factor(
        slid + effect.prior_sliding_m, effect.run_in_drop, effect.run_in_length_m, effect.wear_rate_per_m, effect.form
    )


def drift_factors(
    theta: NDArray, reset: NDArray, geometry: RobotGeometry, effect: FrictionDrift, dt: float
) -> NDArray[np.float64]:
    """Friction multiplier of each guide at each frame [-], shape (T, N-1).

    ``w_k(t) = run_in_wear_factor(s0 + s_k(t), ...)`` with ``s_k`` the guide's sliding distance
    so far (:func:`tendon_id.sliding.guide_sliding_distance`) and ``s0 = effect.prior_sliding_m`` what the guides
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
