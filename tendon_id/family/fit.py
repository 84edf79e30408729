"""The record of one fit of a model's parameters, whatever its family.

A family's fit (a calibration from scratch) and its refit (the diagnosis's local refinement from
a starting point) both return a :class:`Fit`: the parameters by label, the loss, the correlation
of the parameters at the optimum, and the bounds searched. The diagnosis reads the BIC, the
correlations (is a new block confounded with the law?) and the bounds (was it strained to an
edge?) from it, the same way for every family.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

__all__ = ["Fit"]


@dataclass
class Fit:
    """A fitted structure.

    Attributes
    ----------
    model : Estimator or None
        The fitted model (save or predict with it), where the fit made one.
    sse : float
        Sum of squared residuals on the training frames, in the family's loss (a snake's law:
        log tension [-]; a bench passage: N^2 or N^2 m^2).
    n_obs : int
        Residuals in the loss.
    labels : list of str
        Parameter names, the law's first (``n_law`` of them), then ``block:param``.
    n_law : int
        How many of ``labels`` are the law's.
    x : ndarray, shape (P,)
        The parameters at the optimum, in the coordinates the fit searched.
    lower, upper : ndarray, shape (P,)
        The bounds searched (same coordinates).
    corr : ndarray, shape (P, P), optional
        Correlation of the parameters from the Gauss-Newton covariance at the optimum; NaN
        where a parameter does not act.
    n_eval : int
        Model evaluations of the fit (the Jacobian that gives ``corr`` at the optimum is not
        counted).
    seconds : float
        Wall time [s].
    status : str
        The optimiser's stop reason.
    starts : list of float
        The loss reached from each start, where there were several.
    """

    model: object
    sse: float
    n_obs: int
    labels: list
    n_law: int
    x: NDArray
    lower: NDArray
    upper: NDArray
    corr: NDArray | None = None
    n_eval: int = 0
    seconds: float = 0.0
    status: str = ""
    starts: list = field(default_factory=list)

    @property
    def n_params(self) -> int:
        """int : Fitted parameters."""
        return len(self.labels)

    @property
    def rmse(self) -> float:
        """float : Root mean squared residual, in the loss's unit."""
        return float(np.sqrt(self.sse / self.n_obs))

    @property
    def values(self) -> dict[str, float]:
        """dict : ``{label: value}`` at the optimum."""
        return dict(zip(self.labels, np.asarray(self.x, dtype=float).tolist()))

    def bic(self, n_eff: float | None = None) -> float:
        """Bayesian information criterion on the training loss (Schwarz 1978), Gaussian errors.

        ``n ln(SSE / n) + P ln n`` with ``n`` the residual count, or ``n_eff``.
        """
        n = float(self.n_obs if n_eff is None else n_eff)
        return n * np.log(max(self.sse, 1e-300) / self.n_obs) + self.n_params * np.log(n)
