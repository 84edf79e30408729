"""The capstan law's calibration problem: built once, consumed by calibration, posterior and identifiability.

Following pyPESTO's ``Problem`` -> ``Result`` flow, a :class:`LawProblem` holds what the
data and a capstan model's structure say about the law, and each analysis consumes it and
returns its own result:

* :func:`tendon_id.calibration.law.calibrate` -> :class:`~tendon_id.calibration.law.CalibrationResult`
  (nlopt, multi-start where nonsmooth);
* :func:`tendon_id.calibration.posterior.sample_posterior` (emcee, with the likelihood of
  :mod:`tendon_id.calibration.law_posterior`) -> :class:`~tendon_id.calibration.law_posterior.PosteriorResult`;
* :func:`tendon_id.identifiability.analyse` -> :class:`~tendon_id.identifiability.IdentifiabilityResult`
  (through :class:`~tendon_id.identifiability.IdentifiabilityProblem`, a subclass).

The linear design.  For the smooth capstan models the terminal log-drop is linear in the
affine-cosine law (paper Eqs. (4)–(6)):

    ln T[1, N, i] - ln T[N, N, i] = sum_{k < N} m_k alpha_k (A_{k,i} cos alpha_k + B_{k,i}),

with ``m_k`` the exponent factor of the blocks (the contact gate, else 1) and ``alpha_k`` the
backbone wrap with the model's routing wrap, both at the problem's block parameters
(:attr:`LawProblem.values`: the clearance and the routing wrap are fitted, and held fixed
here, :mod:`tendon_id.calibration.law_geometry`).  The per-guide
regressors ``[m alpha cos alpha, m alpha]`` (:attr:`LawProblem.guide_design`) are the whole
story: tying the law across guides sums them, and the sensitivity of ``-ln T[j, j]`` to
guide ``k``'s law is that pair for ``k < j`` and zero beyond.

The weights.  Both load cells have noise ``sigma_i`` [N], so the log residual has variance
``sigma_i^2 (1 / T[1, N]^2 + 1 / T[N, N]^2)`` to first order (the delta method, e.g.
Casella & Berger 2002, "Statistical Inference", §5.5.4): a heteroscedastic Gaussian whose
weights :func:`delta_method_weight` come from the measured tensions.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration.law_layout import LawLayout
from tendon_id.calibration.optimize import Outcome, minimize
from tendon_id.errors import ConfigError


def delta_method_weight(t_in: NDArray, t_out: NDArray) -> NDArray[np.float64]:
    """Weight [N^2] of a log-tension drop ``ln t_in - ln t_out`` read by two noisy load cells.

    With noise ``sigma`` [N] on each reading, ``Var(ln t_in - ln t_out) ~ sigma^2 (1 / t_in^2 +
    1 / t_out^2)`` (delta method, first order), so the residual's weight in
    ``sum w r^2 / sigma^2`` is ``w = 1 / (1 / t_in^2 + 1 / t_out^2)``.

    Parameters
    ----------
    t_in, t_out : ndarray
        Tensions at the two load cells [N], broadcastable.
    """
    return 1.0 / (1.0 / t_in**2 + 1.0 / t_out**2)


def constrained_lstsq(
    X: NDArray, y: NDArray, layout: LawLayout, xtol_rel: float = 1e-10, x0: NDArray | None = None
) -> Outcome:
    """Least squares ``min |y - X x|^2`` over the law's feasible set, with SLSQP on the exact quadratic.

    The objective ``x^T X^T X x - 2 (X^T y)^T x + y^T y`` and its gradient are built once from
    ``X^T X``; the start is ``x0``, else the unconstrained solution moved into the feasible set.

    Parameters
    ----------
    X : ndarray, shape (T, p)
        Design (scale rows by the square root of their weights for weighted least squares).
    y : ndarray, shape (T,)
    layout : LawLayout
        Bounds and linear constraints of the law.
    xtol_rel : float
        Relative parameter tolerance of nlopt.
    x0 : ndarray, shape (p,), optional
        A feasible start.
    """
    M, b, c = X.T @ X, X.T @ y, float(y @ y)
    cons = layout.constraints()
    lb, ub = layout.bounds()
    if x0 is None:
        x0 = layout.project(np.linalg.lstsq(X, y, rcond=None)[0])
    return minimize(
        lambda x: float(x @ M @ x - 2.0 * b @ x + c),
        x0,
        lb=lb,
        ub=ub,
        grad=lambda x: 2.0 * (M @ x - b),
        ineq=(lambda x: cons[0] @ x - cons[1]) if cons is not None else None,
        ineq_jac=cons[0] if cons is not None else None,
        project=layout.project,
        xtol_rel=xtol_rel,
        maxeval=10000,
    )


def guide_design(model, inputs, values: dict) -> NDArray[np.float64]:
    """``[m alpha cos alpha, m alpha]`` per frame and guide, shape (T, K, 2) [rad] (:attr:`LawProblem.guide_design`).

    ``alpha`` is the backbone wrap with the model's routing wrap (its block parameters in
    ``values``, never the robot's metadata) and ``m`` its exponent blocks' factor (the contact
    gate, else 1).
    """
    m = model.exponent_multiplier(inputs, values)[..., 0]  # (T, K)
    wrap = model.backbone(inputs, values)
    # Written into one array, the bits of np.stack([m * wrap * cos(wrap), m * wrap], -1) without its
    # four (T, K) temporaries: the geometry's profile builds this design at every point it tries.
    out = np.empty(wrap.shape + (2,))
    np.multiply(m, wrap, out=out[..., 1])
    np.cos(wrap, out=out[..., 0])
    out[..., 0] *= out[..., 1]  # cos(wrap) * (m * wrap): the same product, so the same bits
    return out


@dataclass(frozen=True)
class LawProblem:
    """Terminal-only data seen through a capstan model's structure, for one tying.

    Build it with :meth:`from_model`.

    Attributes
    ----------
    guide_design : ndarray, shape (T, K, 2), or None
        ``[m alpha cos alpha, m alpha]`` per frame and guide (K = N - 1) [rad]; None in a problem
        let go of it (:meth:`without_design`).
    log_drop : ndarray, shape (T, n)
        ``ln T[1, N, i] - ln T[N, N, i]`` from the measured tensions [-].
    weight : ndarray, shape (T, n)
        Delta-method weights ``1 / (1/T[1,N]^2 + 1/T[N,N]^2)`` [N^2].
    tying : {"tied", "per-guide"}
    inputs : TransmissionInputs
        The data (the forward model and joint-side predictions read it).
    mu_law : {"affine-cosine", "constant"}
    noise_n : float
        Nominal load-cell noise [N] (the recording's ``sensors.noise_n``, else 1 N).
    keep : ndarray of bool, shape (T,)
        Frames that count in the calibration loss: those after the model's ``warmup_s``.
    model : CapstanModel or None
        The model whose structure (blocks) the problem was built from; its forward model
        serves the nonsmooth fits.
    values : dict
        Block parameters ``{block: {param: value}}`` the forward model runs with.
    """

    guide_design: NDArray[np.float64] | None
    log_drop: NDArray[np.float64]
    weight: NDArray[np.float64]
    tying: str
    # Typed in the docstring: this module sits below the zoo (CapstanModel.fit calibrates through it).
    inputs: Any = field(repr=False)
    mu_law: str = "affine-cosine"
    noise_n: float = 1.0
    keep: NDArray[np.bool_] | None = field(default=None, repr=False)
    model: Any = field(default=None, repr=False)
    values: dict = field(default_factory=dict, repr=False)

    @classmethod
    def from_model(
        cls, model, inputs, tying: str | None = None, noise_n: float = 1.0, *, values: dict | None = None
    ) -> LawProblem:
        """Build the problem of ``model``'s structure (law and exponent blocks) on ``inputs``.

        Parameters
        ----------
        model : CapstanModel
            Fitted or not; only its structure and settings are read.
        inputs : TransmissionInputs
        tying : {"tied", "per-guide"}, optional
            Default: the model's.
        noise_n : float
            Nominal load-cell noise [N].
        values : dict, optional
            Block parameters, the routing wrap and the clearance included (default: a fitted
            model's, ``model.block_params_``, else the blocks' initial values,
            ``model.block_params()``).
        """
        if values is None:
            values = model.block_params_ if model.is_fitted else model.block_params()
        design = guide_design(model, inputs, values)
        drop = np.log(inputs.actuator[:, -1]) - np.log(inputs.terminal)
        weight = delta_method_weight(inputs.actuator[:, -1], inputs.terminal)
        keep = inputs.since_start >= float(model.warmup_s)  # frames that count (see CapstanModel.warmup_s)
        return cls(
            design,
            drop,
            weight,
            model.tying if tying is None else tying,
            inputs,
            model.mu_law,
            float(noise_n),
            keep,
            model,
            values,
        )

    # ---- parameters --------------------------------------------------------------------
    @property
    def n_guides(self) -> int:
        return self.guide_design.shape[1] if self.guide_design is not None else self.inputs.n_modules - 1

    def without_design(self) -> LawProblem:
        """This problem with its per-guide design let go (``guide_design`` None), for a fit of the forward model.

        The design is a third of a snake's recording (issue 42's scale); a nonsmooth joint fit never
        reads it, while the base fits it starts from build designs of their own.
        """
        return dataclasses.replace(self, guide_design=None)

    @property
    def n_tendons(self) -> int:
        """Tendons per set: one law each."""
        return self.log_drop.shape[1]

    @property
    def n_groups(self) -> int:
        """Law groups per tendon: 1 (tied) or one per guide."""
        return 1 if self.tying == "tied" else self.n_guides

    @property
    def layout(self) -> LawLayout:
        """Parameter vector of one tendon (``[A_1..A_G, B_1..B_G]``, or ``[mu_1..mu_G]``)."""
        return LawLayout(self.mu_law, self.n_groups)

    @property
    def n_params(self) -> int:
        return self.layout.size

    @cached_property
    def tie_matrix(self) -> NDArray[np.float64]:
        """``G`` with per-guide law ``[A_1..A_K, B_1..B_K] = G theta``, shape (2K, p) (affine-cosine)."""
        k = self.n_guides
        if self.tying == "per-guide":
            return np.eye(2 * k)
        G = np.zeros((2 * k, 2))
        G[:k, 0] = 1.0
        G[k:, 1] = 1.0
        return G

    # ---- designs ------------------------------------------------------------------------
    @cached_property
    def design(self) -> NDArray[np.float64]:
        """Terminal design ``X`` with ``log_drop[:, i] = X theta_i`` (smooth models), shape (T, p).

        Columns ``sum_k m alpha cos alpha`` then ``sum_k m alpha`` (tied), or one pair per guide
        (per-guide); only the second half for the constant law.
        """
        ca, a = self.guide_design[..., 0], self.guide_design[..., 1]
        if self.tying == "tied":
            ca, a = ca.sum(axis=1, keepdims=True), a.sum(axis=1, keepdims=True)
        # Contiguous, so that products with it take the BLAS path whatever the law.
        return np.ascontiguousarray(np.concatenate([ca, a], axis=1) if self.mu_law == "affine-cosine" else a)

    def joint_design(self, joint: int) -> NDArray[np.float64]:
        """Sensitivity of ``ln T[1, j] - ln T[j, j]`` to the parameters, shape (T, p) (affine-cosine).

        ``joint`` is 1-based; set ``j`` passes guides ``1..j-1``.  The law is tied through
        :attr:`tie_matrix`, which sums the guides in order; at ``j = N`` this is :attr:`design`
        up to rounding (that one sums them pairwise).
        """
        if not 1 <= joint <= self.n_guides + 1:
            raise ConfigError(f"joint must be in 1..{self.n_guides + 1}, got {joint}")
        d = self.guide_design[:, : joint - 1]  # (T, j-1, 2)
        per_guide = np.zeros((d.shape[0], 2 * self.n_guides))
        per_guide[:, : joint - 1] = d[..., 0]
        per_guide[:, self.n_guides : self.n_guides + joint - 1] = d[..., 1]
        return per_guide @ self.tie_matrix

    def joint_exponents(self, thetas: NDArray, frames: NDArray | None = None) -> NDArray[np.float64]:
        """``ln T[1, j] - ln T[j, j]`` for laws ``thetas`` (D, p), every joint: shape (D, F, N).

        Column 0 (joint 1) is zero: set 1's joint side is its actuator side.  ``frames``
        picks frames (default all, F = T).
        """
        gd = self.guide_design if frames is None else self.guide_design[frames]
        per_guide = np.asarray(thetas) @ self.tie_matrix.T  # (D, 2K)
        k = self.n_guides
        phi = np.einsum("tk,dk->dtk", gd[..., 0], per_guide[:, :k]) + np.einsum(
            "tk,dk->dtk", gd[..., 1], per_guide[:, k:]
        )
        out = np.zeros(phi.shape[:2] + (k + 1,))
        np.cumsum(phi, axis=2, out=out[:, :, 1:])
        return out

    # ---- weighted Gaussian likelihood -----------------------------------------------------
    def residual_sigma(self, theta: NDArray, tendon: int) -> float:
        """Load-cell noise [N] that explains the residual of law ``theta`` (weighted RMS)."""
        r = self.log_drop[:, tendon] - self.design @ theta
        return float(np.sqrt(np.mean(self.weight[:, tendon] * r**2)))

    def precision(
        self, tendon: int, sigma: float, design: NDArray | None = None, weight: NDArray | None = None
    ) -> NDArray[np.float64]:
        """Fisher information ``X^T W X / sigma^2`` of one tendon's law, shape (p, p)."""
        X = self.design if design is None else design
        w = self.weight[:, tendon] if weight is None else weight
        return X.T @ (w[:, None] * X) / sigma**2

    def quadratic(self, tendon: int, sigma: float = 1.0) -> tuple[NDArray, NDArray, float]:
        """``(M, b, c)`` with ``-2 ln L(theta) = theta^T M theta - 2 b^T theta + c`` (up to a constant).

        ``sum_t w_t (y_t - x_t theta)^2 / sigma^2`` over all frames, ``sigma`` [N] the load-cell noise.
        """
        w = self.weight[:, tendon] / sigma**2
        y = self.log_drop[:, tendon]
        return self.design.T @ (w[:, None] * self.design), self.design.T @ (w * y), float(np.sum(w * y**2))

    # ---- forward model -------------------------------------------------------------------
    def with_values(self, values: dict) -> LawProblem:
        """The same problem at other block parameters (a fitted clearance or routing wrap), built anew."""
        return type(self).from_model(self.model, self.inputs, self.tying, self.noise_n, values=values)

    def terminal_reading(self, A: NDArray, B: NDArray, values: dict | None = None, **kwargs) -> NDArray:
        """The model's predicted terminal reading [N] for law ``(A, B)`` (see ``CapstanModel.terminal_reading``)."""
        return self.model.terminal_reading(self.inputs, A, B, self.values if values is None else values, **kwargs)
