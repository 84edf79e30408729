"""Profile likelihoods of the capstan law (Raue et al. 2009, Bioinformatics 25:1923).

For each parameter (and each guide's ``mu(0) = A + B``) the profile is
``PL(v) = min_{theta: c . theta = v, theta feasible} -2 ln L(theta)``, solved exactly
with nlopt's SLSQP on the quadratic of :meth:`tendon_id.calibration.problem.LawProblem.quadratic`.
Relative to the optimum, ``Delta(v) = PL(v) - PL_min``:

* in the Fisher null space (flat until the feasibility limit): structurally
  unidentifiable;
* crosses the 95 % threshold (chi-square, 1 dof: 3.84) on both sides, or on one side
  while the other is pinned at once by the physical constraint (the estimate sits on
  it): identifiable, with that confidence interval;
* otherwise some side runs to the physical limit (``mu >= 0`` on ``[0, pi]`` and the
  sanity bounds) without crossing: practically unidentifiable, an interval that is
  open to that limit (reported as ``None``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration.law_layout import LawLayout
from tendon_id.calibration.optimize import minimize

#: Pointwise 95 % threshold of the profile likelihood (chi-square quantile, 1 dof).
THRESHOLD_95 = 3.841458820694124


@dataclass
class Profile:
    """One profile likelihood.

    Attributes
    ----------
    name : str
    values, delta : ndarray
        Grid of the profiled combination and ``Delta(v)`` there (inf where infeasible).
    estimate : float
    ci : (float or None, float or None)
        95 % interval; None on a side open to the physical limit.
    ends : (str, str)
        How each side ended: ``"threshold"``, ``"pinned"`` (the constraint is active at the
        estimate) or ``"limit"`` (reached the physical limit below the threshold).
    verdict : {"identifiable", "practically unidentifiable", "structurally unidentifiable"}
    """

    name: str
    values: NDArray[np.float64]
    delta: NDArray[np.float64]
    estimate: float
    ci: tuple[float | None, float | None]
    verdict: str
    ends: tuple[str, str] = ("threshold", "threshold")

    def to_dict(self) -> dict:
        return {"estimate": self.estimate, "ci95": list(self.ci), "ends": list(self.ends), "verdict": self.verdict}


def _range_of(c: NDArray, layout: LawLayout) -> tuple[float, float]:
    """Range of ``c . theta`` over the feasible box of the layout (a safe outer bound)."""
    lb, ub = layout.bounds()
    return float(np.sum(np.where(c > 0, c * lb, c * ub))), float(np.sum(np.where(c > 0, c * ub, c * lb)))


def profile(
    M: NDArray,
    b: NDArray,
    c0: float,
    theta_hat: NDArray,
    direction: NDArray,
    layout: LawLayout,
    name: str,
    *,
    sd: float,
    structural: bool = False,
    n_steps: int = 14,
) -> Profile:
    """Profile ``v = direction . theta`` of ``-2 ln L = theta^T M theta - 2 b^T theta + c0``.

    Steps outwards from the estimate by ``sd * 2^k`` (``sd`` the linearised standard
    deviation, or a fallback scale when infinite) until ``Delta`` passes the 95 %
    threshold, the problem turns infeasible, or the feasible range ends.  ``structural``
    marks a combination in the Fisher null space (:class:`~tendon_id.identifiability.spectrum.Spectrum`).
    """
    cons_C, cons_d = layout.constraints()
    lb, ub = layout.bounds()
    f = lambda x: float(x @ M @ x - 2.0 * b @ x + c0)  # noqa: E731
    g = lambda x: 2.0 * (M @ x - b)  # noqa: E731
    f_hat = f(theta_hat)
    v_hat = float(direction @ theta_hat)
    lo_lim, hi_lim = _range_of(direction, layout)
    step0 = sd if np.isfinite(sd) and sd > 0 else 0.02
    step0 = max(step0, 1e-6 * max(1.0, abs(v_hat)))
    points = [(v_hat, 0.0)]
    x_prev = {1: theta_hat, -1: theta_hat}
    ci: list[float | None] = [None, None]
    ends = ["limit", "limit"]
    for side in (-1, 1):
        prev = (v_hat, 0.0)
        moved = False
        for k in range(n_steps):
            v = v_hat + side * step0 * 0.5 * 2.0**k
            if v < lo_lim or v > hi_lim:
                break
            out = minimize(
                f,
                x_prev[side],
                lb=lb,
                ub=ub,
                grad=g,
                ineq=lambda x: cons_C @ x - cons_d,
                ineq_jac=cons_C,
                eq=(direction[None], np.array([v])),
                xtol_rel=1e-10,
                maxeval=500,
            )
            if not out.feasible:
                break
            moved = True
            x_prev[side] = out.x
            delta = max(out.f - f_hat, 0.0)
            points.append((v, delta))
            if delta > THRESHOLD_95:
                # Linear interpolation of the crossing between the last two points.
                v0, d0 = prev
                ci[0 if side < 0 else 1] = float(v0 + (THRESHOLD_95 - d0) * (v - v0) / (delta - d0))
                ends[0 if side < 0 else 1] = "threshold"
                break
            prev = (v, delta)
        if not moved:
            ends[0 if side < 0 else 1] = "pinned"
            ci[0 if side < 0 else 1] = v_hat
    points.sort()
    values = np.array([p[0] for p in points])
    delta = np.array([p[1] for p in points])
    if structural:
        verdict = "structurally unidentifiable"
    elif "limit" not in ends:
        verdict = "identifiable"
    else:
        verdict = "practically unidentifiable"
    return Profile(
        name=name,
        values=values,
        delta=delta,
        estimate=v_hat,
        ci=(ci[0], ci[1]),
        verdict=verdict,
        ends=(ends[0], ends[1]),
    )
