"""The identifiability study's view of the law problem (:doc:`/guide/identifiability`).

:class:`IdentifiabilityProblem` is the :class:`tendon_id.calibration.problem.LawProblem` (the one
calibration and the posterior consume: design, delta-method weights and layout, built once)
restricted to what the study analyses, the smooth affine-cosine models (``capstan-simple``,
``capstan-contact``), whose terminal log-tension is linear in the law (paper Eqs. (4)–(6)):

    ln T[1, j, i] - ln T[j, j, i] = sum_{k < j} m_k alpha_k (A_{k,i} cos alpha_k + B_{k,i}).

It adds parameter names by guide and tendon and the weighted constrained fit, and takes
its terminal design from the same tie-matrix family as every intermediate joint's
(:meth:`~tendon_id.calibration.problem.LawProblem.joint_design`), so that the terminal row is joint
``N`` of the designs the bands and the advice compare.
"""

from __future__ import annotations

import dataclasses
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration import problem as law_problem
from tendon_id.calibration.problem import constrained_lstsq
from tendon_id.checks import check_choice
from tendon_id.errors import ConfigError
from tendon_id.zoo.capstan import TYINGS, CapstanModel
from tendon_id.zoo.inputs import TransmissionInputs


@dataclasses.dataclass(frozen=True)
class IdentifiabilityProblem(law_problem.LawProblem):
    """Terminal-only data seen through a smooth affine-cosine capstan model, for one tying.

    The attributes are those of :class:`tendon_id.calibration.problem.LawProblem`.
    """

    @classmethod
    def from_model(
        cls,
        model: CapstanModel,
        inputs: TransmissionInputs,
        tying: str | None = None,
        noise_n: float = 1.0,
        *,
        values: dict | None = None,
    ) -> IdentifiabilityProblem:
        """Build the problem of ``model``'s structure (law and exponent blocks) with ``tying``.

        Raises
        ------
        ConfigError
            If ``tying`` is unknown, or the model is not a smooth affine-cosine capstan model.
        """
        tying = model.tying if tying is None else tying
        if tying not in TYINGS:
            check_choice("tying", tying, TYINGS)
        if not isinstance(model, CapstanModel) or model.mu_law != "affine-cosine" or not model.is_smooth:
            raise ConfigError(
                "identifiability is analysed on a smooth affine-cosine capstan model "
                "(capstan-simple or capstan-contact)"
            )
        return super().from_model(model, inputs, tying, noise_n, values=values)

    @cached_property
    def design(self) -> NDArray[np.float64]:
        """Terminal design ``X`` (sensitivity of ``-ln T[N, N]``), shape (T, p): ``joint_design(N)``.

        Equal to the calibration's :attr:`tendon_id.calibration.problem.LawProblem.design` up to rounding
        (the tie matrix sums the guides in order, that one pairwise).
        """
        return self.joint_design(self.n_guides + 1)

    def names(self, tendon: int | None = None) -> list[str]:
        """Parameter names, e.g. ``A``, ``B`` (tied) or ``A_g3`` (per-guide), with ``_t2`` for a tendon."""
        suffix = "" if tendon is None else f"_t{tendon + 1}"
        if self.tying == "tied":
            return [f"A{suffix}", f"B{suffix}"]
        return [f"{p}_g{k + 1}{suffix}" for p in ("A", "B") for k in range(self.n_guides)]

    def fit(self, tendon: int) -> NDArray[np.float64]:
        """Constrained weighted least squares of one tendon's law (nlopt SLSQP, as in calibration).

        A per-guide fit also starts from the tied fit repeated over the guides: with a
        rank-deficient design the projected least-squares start can sit far from the
        feasible optimum, while the tied law is feasible and already fits as well as the
        tied model, so the per-guide fit can only improve on it.
        """
        sw = np.sqrt(self.weight[:, tendon] / np.mean(self.weight[:, tendon]))  # scale-free for SLSQP
        X, y = self.design * sw[:, None], self.log_drop[:, tendon] * sw
        best = constrained_lstsq(X, y, self.layout, 1e-10)
        if self.tying == "per-guide":
            a, b = dataclasses.replace(self, tying="tied").fit(tendon)
            start = self.layout.join(np.full(self.n_groups, a), np.full(self.n_groups, b))
            other = constrained_lstsq(X, y, self.layout, 1e-10, x0=start)
            if other.feasible and other.f < best.f:
                best = other
        return best.x
