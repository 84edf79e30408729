"""The Euler–Eytelwein capstan relation through one guide."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def capstan_exponent(mu: ArrayLike, alpha: ArrayLike, beta: ArrayLike = 1.0) -> NDArray[np.float64]:
    """Capstan exponent ``phi = beta * mu * alpha``, paper Eq. (5) with the gate of Eq. (6).

    Parameters
    ----------
    mu : array_like
        Friction coefficient [-].
    alpha : array_like
        Wrap angle [rad].
    beta : array_like, optional
        Contact gate in ``[0, 1]`` (1: in contact).

    Returns
    -------
    ndarray
        ``phi >= 0`` [-] when ``mu >= 0``.
    """
    return np.asarray(beta, dtype=float) * np.asarray(mu, dtype=float) * np.asarray(alpha, dtype=float)


def capstan_ratio(phi: ArrayLike, sigma: ArrayLike = 1.0) -> NDArray[np.float64]:
    """Tension ratio ``T_out / T_in = exp(-sigma * phi)``, paper Eq. (6).

    Parameters
    ----------
    phi : array_like
        Capstan exponent [-] from :func:`capstan_exponent`.
    sigma : array_like, optional
        Slip state: +1 forward slip (pulling, tension drops), -1 reverse slip,
        0 stick (the ratio is then 1 in Eq. (6); the nonsmooth model instead
        keeps the previous output, see :func:`friction_models.play_operator`).
    """
    return np.exp(-np.asarray(sigma, dtype=float) * np.asarray(phi, dtype=float))
