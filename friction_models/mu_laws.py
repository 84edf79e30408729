"""Friction-coefficient laws mu(alpha) for a tendon sliding through a guide."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def affine_cosine_mu(alpha: ArrayLike, A: ArrayLike, B: ArrayLike) -> NDArray[np.float64]:
    """Affine-cosine friction law, paper Eq. (4): ``mu(alpha) = A cos(alpha) + B``.

    Parameters
    ----------
    alpha : array_like
        Wrap angle [rad], any shape.
    A, B : array_like
        Per-tendon law parameters [-], broadcast against ``alpha`` (the last
        axis is usually the tendon axis of length 3).

    Returns
    -------
    ndarray
        Friction coefficient [-].  ``mu >= 0`` on ``[0, pi]`` iff ``B >= |A|``.
    """
    alpha = np.asarray(alpha, dtype=float)
    return np.asarray(A, dtype=float) * np.cos(alpha) + np.asarray(B, dtype=float)


def constant_mu(alpha: ArrayLike, mu: ArrayLike) -> NDArray[np.float64]:
    """The classic Euler–Eytelwein constant coefficient, broadcast to ``alpha``'s shape.

    Parameters
    ----------
    alpha : array_like
        Wrap angle [rad]; only its shape is used.
    mu : array_like
        Friction coefficient [-], broadcast against ``alpha``.
    """
    alpha = np.asarray(alpha, dtype=float)
    return np.broadcast_to(np.asarray(mu, dtype=float), np.broadcast_shapes(alpha.shape, np.shape(mu))).copy()


def velocity_dependent_mu(
    mu_static: ArrayLike,
    sliding_speed: ArrayLike,
    v_ref: float = 0.01,
    stribeck_drop: float = 0.0,
    v_stribeck: float = 0.002,
) -> NDArray[np.float64]:
    """Speed-dependent friction: a Stribeck dip plus a viscous rise.

    ``mu(v) = mu_s * (1 - d * (1 - exp(-(v / v_s)^2)) + |v| / v_ref)``.
    With ``d = 0`` this is purely viscous friction, ``mu_s (1 + |v| / v_ref)``
    (Olsson et al., "Friction models and friction compensation", Eur. J.
    Control 4(3), 1998, Eqs. 5–7, written multiplicatively on the static law).

    Parameters
    ----------
    mu_static : array_like
        Quasi-static coefficient [-], e.g. from :func:`affine_cosine_mu`.
    sliding_speed : array_like
        Tendon sliding speed through the guide [m/s] (sign ignored).
    v_ref : float
        Speed at which viscous friction doubles ``mu`` [m/s].
    stribeck_drop : float
        Fractional drop ``d`` from static to kinetic friction, in ``[0, 1)``.
    v_stribeck : float
        Stribeck speed ``v_s`` [m/s].
    """
    if v_ref <= 0 or v_stribeck <= 0:
        raise ValueError("v_ref and v_stribeck must be positive speeds in m/s")
    if not 0.0 <= stribeck_drop < 1.0:
        raise ValueError("stribeck_drop must lie in [0, 1)")
    v = np.abs(np.asarray(sliding_speed, dtype=float))
    dip = stribeck_drop * (1.0 - np.exp(-((v / v_stribeck) ** 2)))
    return np.asarray(mu_static, dtype=float) * (1.0 - dip + v / v_ref)


def speed_factor(sliding_speed: ArrayLike, slope: ArrayLike) -> NDArray[np.float64]:
    """The factor on ``mu`` of friction that changes with sliding speed, by its slope at rest.

    ``1 + s |v|`` for ``s >= 0``: viscous friction (Olsson et al., "Friction models and friction
    compensation", Eur. J. Control 4(3), 1998, Eq. 5, written multiplicatively; ``s = 1 / v_ref``
    of :func:`velocity_dependent_mu`).  ``exp(s |v|)`` for ``s < 0``: velocity weakening, friction
    that falls as the tendon starts to slide (the Stribeck effect, ibid. Eq. 7), in a form that
    stays positive at any speed.  Both have the slope ``s`` at rest, so the factor is smooth in
    ``s`` through 0, where it is 1 (Coulomb friction).

    Parameters
    ----------
    sliding_speed : array_like
        Tendon sliding speed through the guide [m/s] (sign ignored).
    slope : array_like
        ``s`` [s/m], broadcast against the speed.
    """
    v = np.abs(np.asarray(sliding_speed, dtype=float))
    s = np.asarray(slope, dtype=float)
    return np.where(s >= 0, 1.0 + np.maximum(s, 0.0) * v, np.exp(np.minimum(s, 0.0) * v))
