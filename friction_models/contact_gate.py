"""Tendon–guide contact gate beta(alpha) from the hole's clearance angle."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def hard_contact_gate(alpha: ArrayLike, alpha_c: float) -> NDArray[np.float64]:
    """Contact indicator ``beta = 1[alpha > alpha_c]`` (paper Eq. (6); :doc:`/guide/geometry`).

    A tendon that turns by less than the clearance angle ``alpha_c`` of the hole
    passes without touching its wall and loses no tension there.

    Parameters
    ----------
    alpha : array_like
        Wrap angle [rad].
    alpha_c : float
        Clearance angle of the hole [rad], ``>= 0``.

    Returns
    -------
    ndarray of float
        0.0 or 1.0, same shape as ``alpha``.
    """
    if alpha_c < 0:
        raise ValueError("alpha_c must be a non-negative angle in rad")
    return (np.asarray(alpha, dtype=float) > alpha_c).astype(float)


def smooth_contact_gate(alpha: ArrayLike, alpha_c: float, width: float = 0.01) -> NDArray[np.float64]:
    """Differentiable contact gate ``sigmoid((alpha - alpha_c) / width)``.

    Tends to :func:`hard_contact_gate` as ``width -> 0``; used where gradients
    with respect to the wrap are needed.

    Parameters
    ----------
    alpha : array_like
        Wrap angle [rad].
    alpha_c : float
        Clearance angle [rad].
    width : float
        Transition width [rad], ``> 0``.
    """
    if width <= 0:
        raise ValueError("width must be a positive angle in rad")
    z = (np.asarray(alpha, dtype=float) - alpha_c) / width
    # 0.5 * (1 + tanh(z/2)) is the logistic function without overflow for large |z|.
    return 0.5 * (1.0 + np.tanh(0.5 * z))


def dead_zone_wrap(alpha: ArrayLike, alpha_c: float) -> NDArray[np.float64]:
    """Wrap that presses on the hole's wall, ``alpha_eff = max(alpha - alpha_c, 0)`` [rad] (:doc:`/guide/geometry`).

    A tendon in a hole with radial clearance turns freely through the clearance angle
    ``alpha_c``; only the rest of its turn is taken by contact with the wall, so the
    capstan exponent grows from zero continuously as the wrap passes ``alpha_c`` instead of
    jumping there as with :func:`hard_contact_gate`.  It is the clearance treated as the
    dead-zone nonlinearity of a backlash (Tao & Kokotovic, "Adaptive control of plants
    with unknown dead-zones", IEEE Trans. Autom. Control 39(1):59-68, 1994), applied to the
    wrap that enters the capstan exponent of the guide (paper Eq. (5)).

    Parameters
    ----------
    alpha : array_like
        Wrap angle [rad].
    alpha_c : float
        Clearance angle of the hole [rad], ``>= 0``.

    Returns
    -------
    ndarray of float
        Effective wrap [rad], same shape as ``alpha``, in ``[0, alpha]``.
    """
    if alpha_c < 0:
        raise ValueError("alpha_c must be a non-negative angle in rad")
    return np.maximum(np.asarray(alpha, dtype=float) - alpha_c, 0.0)
