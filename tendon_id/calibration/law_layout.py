"""The capstan law's parameter vector per tendon and its feasible set (:doc:`/guide/calibration`).

The affine-cosine law ``mu(alpha) = A cos(alpha) + B`` (paper Eq. (4)) is affine in
``cos(alpha) in [-1, 1]``, so its minimum over ``[0, pi]`` is at an end and

    mu(alpha) >= 0 on [0, pi]  <=>  A + B >= 0 and B - A >= 0  <=>  B >= |A|,

two linear inequalities per group (guide group) and tendon.  Two sanity limits close the
set: ``mu(0) = A + B <= MU_MAX`` and ``A >= R_MIN mu(0) / 2``.  The constant law
(Euler–Eytelwein) has one parameter ``mu`` per group, in ``[0, MU_MAX]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: Upper bound on mu(0) = A + B [-]; no tendon–guide pair comes near it.
MU_MAX = 2.0
#: Lower bound on r = 2 A / mu(0): A may be as negative as 10 mu(0) (mu rising 21-fold by pi).
R_MIN = -20.0


@dataclass(frozen=True)
class LawLayout:
    """Per-tendon parameter vector ``[A_1..A_G, B_1..B_G]`` (affine-cosine) or ``[mu_1..mu_G]``.

    The feasible set of a group is ``B >= |A|`` (``mu >= 0`` on ``[0, pi]``), with the
    sanity limits ``mu(0) = A + B <= MU_MAX`` and ``A >= R_MIN mu(0) / 2``.  Derivative-free
    fits work in the free coordinates ``(mu0, r)`` with ``A = r mu0 / 2`` and
    ``B = mu0 - A``: every point of the box ``0 <= mu0 <= MU_MAX``, ``R_MIN <= r <= 1``
    is feasible, so COBYLA needs no constraint and ``mu0``, the best-determined
    combination, is a coordinate.

    Parameters
    ----------
    mu_law : {"affine-cosine", "constant"}
    n_groups : int
        Law groups per tendon: 1 (tied) or N - 1 (per-guide).
    """

    mu_law: str
    n_groups: int

    @property
    def size(self) -> int:
        """Parameters per tendon."""
        return self.n_groups * (2 if self.mu_law == "affine-cosine" else 1)

    def split(self, x: NDArray) -> tuple[NDArray, NDArray]:
        """``(A, B)`` of a vector (or of the leading axis of an array); ``A`` is zero for the constant law."""
        g = self.n_groups
        if self.mu_law == "affine-cosine":
            return x[:g], x[g : 2 * g]
        return np.zeros_like(x[:g]), x[:g]

    def join(self, A: NDArray, B: NDArray) -> NDArray:
        """The parameter vector of ``(A, B)`` (``B`` alone, as mu, for the constant law)."""
        return np.concatenate([A, B]) if self.mu_law == "affine-cosine" else np.asarray(B, dtype=float)

    def bounds(self) -> tuple[NDArray, NDArray]:
        """Box ``(lb, ub)`` that contains the feasible set (the constraints cut it further)."""
        g = self.n_groups
        if self.mu_law == "affine-cosine":
            return (
                np.r_[np.full(g, R_MIN * MU_MAX / 2), np.zeros(g)],
                np.r_[np.full(g, MU_MAX / 2), np.full(g, MU_MAX * (1 - R_MIN / 2))],
            )
        return np.zeros(g), np.full(g, MU_MAX)

    def constraints(self) -> tuple[NDArray, NDArray] | None:
        """Linear constraints ``C x <= d`` of the feasible set (affine-cosine law).

        Rows per group: ``A - B <= 0``, ``-A - B <= 0`` (together ``B >= |A|``),
        ``A + B <= MU_MAX`` and ``R_MIN (A + B) / 2 - A <= 0``.
        """
        if self.mu_law != "affine-cosine":
            return None
        g = self.n_groups
        eye, zero = np.eye(g), np.zeros(g)
        C = np.block([[eye, -eye], [-eye, -eye], [eye, eye], [-(1 - R_MIN / 2) * eye, -(-R_MIN / 2) * eye]])
        d = np.r_[zero, zero, np.full(g, MU_MAX), zero]
        return C, d

    def feasible(self, x: NDArray, tol: float = 1e-12) -> NDArray[np.bool_]:
        """Feasibility of draws ``x`` of shape (..., size)."""
        A, B = self.split(np.moveaxis(np.asarray(x, dtype=float), -1, 0))
        if self.mu_law != "affine-cosine":
            return np.all((B >= -tol) & (B <= MU_MAX + tol), axis=0)
        mu0 = A + B
        return np.all((B >= np.abs(A) - tol) & (mu0 <= MU_MAX + tol) & (A >= R_MIN * mu0 / 2 - tol), axis=0)

    def to_free(self, x: NDArray) -> NDArray:
        """``(A, B)`` to the free box coordinates ``(mu0, r)``."""
        if self.mu_law != "affine-cosine":
            return np.asarray(x, dtype=float)
        A, B = self.split(np.asarray(x, dtype=float))
        mu0 = np.clip(A + B, 0.0, MU_MAX)
        r = np.divide(2 * A, mu0, out=np.zeros_like(mu0), where=mu0 > 0)
        return np.concatenate([mu0, np.clip(r, R_MIN, 1.0)])

    def from_free(self, z: NDArray) -> NDArray:
        """Free coordinates back to ``(A, B)``; always feasible."""
        if self.mu_law != "affine-cosine":
            return np.asarray(z, dtype=float)
        g = self.n_groups
        mu0, r = z[:g], z[g:]
        A = 0.5 * r * mu0
        return self.join(A, mu0 - A)

    def free_bounds(self) -> tuple[NDArray, NDArray]:
        """The box of the free coordinates ``(mu0, r)``: ``[0, MU_MAX]`` and ``[R_MIN, 1]``."""
        g = self.n_groups
        if self.mu_law != "affine-cosine":
            return np.zeros(g), np.full(g, MU_MAX)
        return np.r_[np.zeros(g), np.full(g, R_MIN)], np.r_[np.full(g, MU_MAX), np.ones(g)]

    def project(self, x: NDArray) -> NDArray:
        """The nearest-in-spirit feasible point: through the free coordinates."""
        return self.from_free(self.to_free(x))

    def random_feasible(self, rng: np.random.Generator, around: NDArray) -> NDArray:
        """A random feasible start: ``mu(0)`` scaled by 0.5–1.5 from ``around``, ``r`` uniform in [-2, 1]."""
        z = self.to_free(around)
        g = self.n_groups
        z[:g] = np.clip(np.maximum(z[:g], 1e-3) * rng.uniform(0.5, 1.5, size=g), 0.0, MU_MAX)
        if self.mu_law == "affine-cosine":
            z[g:] = rng.uniform(-2.0, 1.0, size=g)
        return self.from_free(z)
