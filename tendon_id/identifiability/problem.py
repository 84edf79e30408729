"""The capstan law as a linear-Gaussian problem in its parameters (DESIGN §12).

For the smooth capstan models (``capstan-simple``, ``capstan-contact``) the
terminal log-tension is linear in the affine-cosine law (paper Eqs. (4)–(6)):

    ln T[1, j, i] - ln T[j, j, i] = sum_{k < j} m_k alpha_k (A_{k,i} cos alpha_k + B_{k,i}),

with ``m_k`` the contact gate (1 without it).  The per-guide regressors
``[m alpha cos alpha, m alpha]`` of every guide are therefore the whole story:
the sensitivity (Jacobian) of ``-ln T[j, j]`` to the law of guide ``k`` is that
pair for ``k < j`` and zero beyond, and tying the law across guides sums them.

Noise: both load cells have noise ``sigma_i`` [N], so the log residual has
variance ``sigma_i^2 (1 / T[1, N]^2 + 1 / T[N, N]^2)`` to first order (the delta
method, as in :mod:`tendon_id.posterior`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration import LawLayout, _fit_quadratic, minimize
from tendon_id.errors import ConfigError
from tendon_id.zoo.capstan import CapstanModel
from tendon_id.zoo.inputs import TransmissionInputs

TYINGS = ("tied", "per-guide")


@dataclass(frozen=True)
class LawProblem:
    """Terminal-only data seen through a smooth capstan model, for one tying.

    Attributes
    ----------
    guide_design : ndarray, shape (T, K, 2)
        ``[m alpha cos alpha, m alpha]`` per frame and guide (K = N - 1) [rad].
    log_drop : ndarray, shape (T, 3)
        ``ln T[1, N, i] - ln T[N, N, i]`` from the measured tensions [-].
    weight : ndarray, shape (T, 3)
        Delta-method weights ``1 / (1/T[1,N]^2 + 1/T[N,N]^2)`` [N^2].
    tying : {"tied", "per-guide"}
    inputs : TransmissionInputs
        The data (actuator tensions are needed for joint-side predictions).
    noise_n : float
        Nominal load-cell noise [N] (the recording's ``sensors.noise_n``, else 1 N).
    """

    guide_design: NDArray[np.float64]
    log_drop: NDArray[np.float64]
    weight: NDArray[np.float64]
    tying: str
    inputs: TransmissionInputs
    noise_n: float = 1.0

    @classmethod
    def from_model(cls, model: CapstanModel, inputs: TransmissionInputs, tying: str, noise_n: float = 1.0) -> LawProblem:
        """Build the problem of ``model``'s structure (law and exponent blocks) with ``tying``."""
        if tying not in TYINGS:
            raise ConfigError(f"tying must be one of {TYINGS}, got {tying!r}")
        if not isinstance(model, CapstanModel) or model.mu_law != "affine-cosine" or not model.is_smooth:
            raise ConfigError("identifiability is analysed on a smooth affine-cosine capstan model "
                              "(capstan-simple or capstan-contact)")
        m = model.exponent_multiplier(inputs)[..., 0]  # (T, K) contact gate
        wrap = inputs.wrap
        design = np.stack([m * wrap * np.cos(wrap), m * wrap], axis=-1)
        drop = np.log(inputs.actuator[:, -1]) - np.log(inputs.terminal)
        weight = 1.0 / (1.0 / inputs.actuator[:, -1] ** 2 + 1.0 / inputs.terminal**2)
        return cls(design, drop, weight, tying, inputs, float(noise_n))

    # ---- parameters --------------------------------------------------------------------
    @property
    def n_guides(self) -> int:
        return self.guide_design.shape[1]

    @property
    def n_groups(self) -> int:
        return 1 if self.tying == "tied" else self.n_guides

    @property
    def layout(self) -> LawLayout:
        """Parameter vector ``[A_1..A_G, B_1..B_G]`` of one tendon (calibration's layout)."""
        return LawLayout("affine-cosine", self.n_groups)

    @property
    def n_params(self) -> int:
        return self.layout.size

    def names(self, tendon: int | None = None) -> list[str]:
        """Parameter names, e.g. ``A``, ``B`` (tied) or ``A_g3`` (per-guide), with ``_t2`` for a tendon."""
        suffix = "" if tendon is None else f"_t{tendon + 1}"
        if self.tying == "tied":
            return [f"A{suffix}", f"B{suffix}"]
        return [f"{p}_g{k + 1}{suffix}" for p in ("A", "B") for k in range(self.n_guides)]

    @cached_property
    def tie_matrix(self) -> NDArray[np.float64]:
        """``G`` with per-guide law ``[A_1..A_K, B_1..B_K] = G theta``, shape (2K, p)."""
        k = self.n_guides
        if self.tying == "per-guide":
            return np.eye(2 * k)
        G = np.zeros((2 * k, 2))
        G[:k, 0] = 1.0
        G[k:, 1] = 1.0
        return G

    # ---- designs ------------------------------------------------------------------------
    def joint_design(self, joint: int) -> NDArray[np.float64]:
        """Sensitivity of ``ln T[1, j] - ln T[j, j]`` to the parameters, shape (T, p).

        ``joint`` is 1-based; set ``j`` passes guides ``1..j-1``.
        """
        if not 1 <= joint <= self.n_guides + 1:
            raise ConfigError(f"joint must be in 1..{self.n_guides + 1}, got {joint}")
        d = self.guide_design[:, : joint - 1]  # (T, j-1, 2)
        per_guide = np.zeros((d.shape[0], 2 * self.n_guides))
        per_guide[:, : joint - 1] = d[..., 0]
        per_guide[:, self.n_guides : self.n_guides + joint - 1] = d[..., 1]
        return per_guide @ self.tie_matrix

    @cached_property
    def design(self) -> NDArray[np.float64]:
        """Terminal design ``X`` (sensitivity of ``-ln T[N, N]``), shape (T, p)."""
        return self.joint_design(self.n_guides + 1)

    def joint_exponents(self, thetas: NDArray) -> NDArray[np.float64]:
        """``ln T[1, j] - ln T[j, j]`` for laws ``thetas`` (D, p), every joint: shape (D, T, N).

        Column 0 (joint 1) is zero: set 1's joint side is its actuator side.
        """
        per_guide = np.asarray(thetas) @ self.tie_matrix.T  # (D, 2K)
        k = self.n_guides
        phi = (np.einsum("tk,dk->dtk", self.guide_design[..., 0], per_guide[:, :k])
               + np.einsum("tk,dk->dtk", self.guide_design[..., 1], per_guide[:, k:]))
        out = np.zeros(phi.shape[:2] + (k + 1,))
        np.cumsum(phi, axis=2, out=out[:, :, 1:])
        return out

    # ---- likelihood ----------------------------------------------------------------------
    def fit(self, tendon: int) -> NDArray[np.float64]:
        """Constrained weighted least squares of one tendon's law (nlopt SLSQP, as in calibration).

        A per-guide fit also starts from the tied fit repeated over the guides: with a
        rank-deficient design the projected least-squares start can sit far from the
        feasible optimum, while the tied law is feasible and already fits as well as the
        tied model, so the per-guide fit can only improve on it.
        """
        sw = np.sqrt(self.weight[:, tendon] / np.mean(self.weight[:, tendon]))  # scale-free for SLSQP
        X, y = self.design * sw[:, None], self.log_drop[:, tendon] * sw
        best = _fit_quadratic(X, y, self.layout, 1e-10)
        if self.tying == "per-guide":
            tied = LawProblem(self.guide_design, self.log_drop, self.weight, "tied", self.inputs, self.noise_n)
            a, b = tied.fit(tendon)
            start = self.layout.join(np.full(self.n_groups, a), np.full(self.n_groups, b))
            M, q = X.T @ X, X.T @ y
            C, d = self.layout.constraints()
            lb, ub = self.layout.bounds()
            other = minimize(lambda x: float(x @ M @ x - 2.0 * q @ x + y @ y), start, lb=lb, ub=ub,
                             grad=lambda x: 2.0 * (M @ x - q), ineq=lambda x: C @ x - d, ineq_jac=C,
                             project=self.layout.project, xtol_rel=1e-10, maxeval=10000)
            if other.feasible and other.f < best.f:
                best = other
        return best.x

    def residual_sigma(self, theta: NDArray, tendon: int) -> float:
        """Load-cell noise [N] that explains the residual of law ``theta`` (weighted RMS)."""
        r = self.log_drop[:, tendon] - self.design @ theta
        return float(np.sqrt(np.mean(self.weight[:, tendon] * r**2)))

    def precision(self, tendon: int, sigma: float, design: NDArray | None = None,
                  weight: NDArray | None = None) -> NDArray[np.float64]:
        """Fisher information ``X^T W X / sigma^2`` of one tendon's law, shape (p, p)."""
        X = self.design if design is None else design
        w = self.weight[:, tendon] if weight is None else weight
        return X.T @ (w[:, None] * X) / sigma**2

    def quadratic(self, tendon: int, sigma: float) -> tuple[NDArray, NDArray, float]:
        """``(M, b, c)`` with ``-2 ln L(theta) = theta^T M theta - 2 b^T theta + c`` (up to a constant)."""
        w = self.weight[:, tendon] / sigma**2
        y = self.log_drop[:, tendon]
        return self.design.T @ (w[:, None] * self.design), self.design.T @ (w * y), float(np.sum(w * y**2))
