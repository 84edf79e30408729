"""The truth's friction law and the transmission's result (:doc:`/guide/simulator`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from friction_models import affine_cosine_mu
from tendon_id.errors import ConfigError

__all__ = ["FrictionLaw", "TransmissionResult"]


@dataclass(frozen=True)
class FrictionLaw:
    """Per-tendon affine-cosine law ``mu_i(alpha) = A_i cos(alpha) + B_i`` (paper Eq. (4)).

    Parameters
    ----------
    A : tuple of float
        Cosine coefficients ``A_i`` [-], one per tendon of a set (``robot.n_tendons`` of them).
        Default: the paper's identified ``(0.30, 0.32, 0.28)`` (Section IV-B).
    B : tuple of float
        Offsets ``B_i`` [-], as many. Default: the paper's ``(0.09, 0.08, 0.10)``.

    Notes
    -----
    The paper's values have ``B < |A|``: their mu turns negative beyond
    ``alpha = arccos(-B/A)`` (about 105 deg), far outside the wraps a snake's
    guides reach.  The truth law is therefore only required to be positive
    on the wraps a simulation actually visits (checked in :func:`transmit`),
    not on all of ``[0, pi]`` as the calibration constraint ``B >= |A|`` is.
    """

    A: tuple[float, ...] = (0.30, 0.32, 0.28)
    B: tuple[float, ...] = (0.09, 0.08, 0.10)

    def __post_init__(self) -> None:
        A = tuple(float(a) for a in self.A)
        B = tuple(float(b) for b in self.B)
        if len(A) < 2 or len(A) != len(B):
            raise ConfigError(
                f"friction.A and friction.B need one value per tendon of a set, as many each, got {len(A)} and {len(B)}"
            )
        for i, (a, b) in enumerate(zip(A, B), start=1):
            if a + b <= 0:
                raise ConfigError(f"friction law of tendon {i} needs mu(0) = A + B > 0, got A={a}, B={b}")
        object.__setattr__(self, "A", A)
        object.__setattr__(self, "B", B)

    def mu(self, alpha: NDArray) -> NDArray:
        """``mu_i(alpha)`` with the tendon on the last axis of ``alpha``."""
        return affine_cosine_mu(alpha, np.array(self.A), np.array(self.B))


@dataclass(frozen=True)
class TransmissionResult:
    """Noise-free transmission state of a block of frames.

    Attributes
    ----------
    chain : ndarray, shape (T, N, N, 3)
        ``chain[t, k-1, j-1, i-1] = T[k, j, i]`` [N]: tension of tendon ``i`` of set
        ``j`` just after guide ``k - 1``; NaN where ``k > j`` (not on the path).
    sigma : ndarray of int8, shape (T, N-1, N, 3)
        Slip state at guide ``k`` for set ``j`` (+1 forward slip, 0 stick, -1
        reverse slip); 0 where set ``j`` does not pass guide ``k``.  Without
        ``stick_slip`` every passing tendon is in forward slip.
    wrap : ndarray, shape (T, N-1)
        Backbone wrap per guide [rad].
    phi : ndarray, shape (T, N-1, N, 3), or None
        Capstan exponent actually applied (NaN off the path); None unless
        :func:`transmit` was asked for it (``with_phi=True``).
    """

    chain: NDArray[np.float64]
    sigma: NDArray[np.int8]
    wrap: NDArray[np.float64]
    phi: NDArray[np.float64] | None = None

    @property
    def joint_side(self) -> NDArray[np.float64]:
        """``T[j, j, :]`` for every set, shape (T, N, 3) [N]."""
        n = self.chain.shape[1]
        return self.chain[:, np.arange(n), np.arange(n), :]
