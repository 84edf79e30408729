"""The one place nlopt is called: :func:`minimize`, wrapped defensively (:doc:`/guide/calibration`).

nlopt's defaults never stop and its exceptions lose the best point found, so the wrapper
sets relative tolerances and an evaluation budget, remembers the best *feasible* point it
has evaluated (returned when nlopt stops on ``RoundoffLimited`` or ``ForcedStop``), checks
feasibility after COBYLA (restored from that point or by projection), and hands nlopt
plain Python floats (a non-finite objective is reported as the largest float, not NaN).
Calibration (:mod:`tendon_id.calibration.law`), the problem's constrained least squares
(:func:`tendon_id.calibration.problem.constrained_lstsq`) and the profile likelihoods
(:mod:`tendon_id.identifiability.profile`) all go through it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import nlopt
import numpy as np
from numpy.typing import NDArray

#: Constraint tolerance for feasibility checks.
CTOL = 1e-9

_STATUS = {
    nlopt.SUCCESS: "success",
    nlopt.STOPVAL_REACHED: "stopval_reached",
    nlopt.FTOL_REACHED: "ftol_reached",
    nlopt.XTOL_REACHED: "xtol_reached",
    nlopt.MAXEVAL_REACHED: "maxeval_reached",
    nlopt.MAXTIME_REACHED: "maxtime_reached",
}


@dataclass
class Outcome:
    """Result of one :func:`minimize` call.

    Attributes
    ----------
    x : ndarray
        The point returned (the best feasible one seen, where nlopt's own end is worse or infeasible).
    f : float
        Objective at ``x``.
    status : str
        nlopt's stop reason, e.g. ``"xtol_reached"`` or ``"roundoff_limited"``.
    n_eval : int
        Objective evaluations.
    feasible : bool
        Whether ``x`` satisfies the bounds and constraints to :data:`CTOL`.
    """

    x: NDArray[np.float64]
    f: float
    status: str
    n_eval: int
    feasible: bool


def minimize(
    fun: Callable[[NDArray], float],
    x0: NDArray,
    *,
    lb: NDArray,
    ub: NDArray,
    grad: Callable[[NDArray], NDArray] | None = None,
    ineq: Callable[[NDArray], NDArray] | None = None,
    ineq_jac: NDArray | None = None,
    eq: tuple[NDArray, NDArray] | None = None,
    project: Callable[[NDArray], NDArray] | None = None,
    xtol_rel: float = 1e-8,
    ftol_rel: float = 1e-14,
    maxeval: int = 1000,
    initial_step: NDArray | None = None,
    fun_grad: Callable[[NDArray], tuple[float, NDArray]] | None = None,
) -> Outcome:
    """Minimise ``fun`` under ``lb <= x <= ub`` and ``ineq(x) <= 0`` with nlopt.

    Uses ``LD_SLSQP`` (Kraft 1988, "A software package for sequential quadratic programming")
    when ``grad`` is given (``ineq`` must then be linear with Jacobian ``ineq_jac``), else the
    derivative-free ``LN_COBYLA`` (Powell 1994, "A direct search optimization method that models
    the objective and constraint functions by linear interpolation").

    Parameters
    ----------
    fun : callable
        Objective of a 1-D float array.
    x0, lb, ub : ndarray
        Start and bounds.
    grad : callable, optional
        Gradient of ``fun``.
    ineq : callable, optional
        Vector of constraint values, feasible when all ``<= 0``.
    ineq_jac : ndarray, optional
        Constant Jacobian of ``ineq`` (linear constraints), for SLSQP.
    eq : (ndarray, ndarray), optional
        Linear equality constraints ``E x = e`` as ``(E, e)`` (SLSQP only; the profile
        likelihoods of :mod:`tendon_id.identifiability` fix a combination this way).
    project : callable, optional
        Maps a slightly infeasible point onto the feasible set.
    xtol_rel, ftol_rel, maxeval :
        Stopping rules.
    fun_grad : callable, optional
        ``x -> (fun(x), grad(x))`` in one pass, where nlopt asks for both: one evaluation of
        what they share instead of two. It stands for ``grad`` (SLSQP) where that is not given.
    initial_step : ndarray, optional
        COBYLA's first step per parameter (its trust region only shrinks from there); default a
        tenth of each parameter's size, at least a thousandth of its bounds' width.

    Returns
    -------
    Outcome
    """
    n = len(x0)
    if grad is None and fun_grad is not None:
        grad = lambda x: fun_grad(x)[1]  # noqa: E731 - SLSQP asks for both through fun_grad
    algorithm = nlopt.LD_SLSQP if grad is not None else nlopt.LN_COBYLA
    opt = nlopt.opt(algorithm, n)
    lb = np.asarray(lb, dtype=float)
    ub = np.asarray(ub, dtype=float)
    opt.set_lower_bounds(lb)
    opt.set_upper_bounds(ub)
    best = {"x": None, "f": np.inf, "n": 0}

    if eq is not None and grad is None:
        raise ValueError("equality constraints need the gradient-based SLSQP (pass grad)")

    def feasible(x: NDArray) -> bool:
        if np.any(x < lb - CTOL) or np.any(x > ub + CTOL):
            return False
        if eq is not None and np.any(np.abs(eq[0] @ x - eq[1]) > 1e3 * CTOL):
            return False
        return ineq is None or bool(np.all(ineq(x) <= CTOL))

    def objective(x, g):
        x = np.asarray(x, dtype=float)
        best["n"] += 1
        if g.size > 0 and fun_grad is not None:
            f, gx = fun_grad(x)
            f = float(f)
            g[:] = np.asarray(gx, dtype=float)
        else:
            f = float(fun(x))
            if g.size > 0:
                g[:] = np.asarray(grad(x), dtype=float)
        if np.isfinite(f) and f < best["f"] and feasible(x):
            best["x"], best["f"] = x.copy(), f
        return f if np.isfinite(f) else float(np.finfo(float).max)

    opt.set_min_objective(objective)
    if ineq is not None:
        m = len(ineq(np.asarray(x0, dtype=float)))

        def constraints(result, x, g):
            result[:] = np.asarray(ineq(np.asarray(x, dtype=float)), dtype=float)
            if g.size > 0:
                g[:] = ineq_jac

        opt.add_inequality_mconstraint(constraints, [CTOL] * m)
    if eq is not None:
        E = np.atleast_2d(np.asarray(eq[0], dtype=float))
        e = np.atleast_1d(np.asarray(eq[1], dtype=float))

        def equalities(result, x, g):
            result[:] = E @ np.asarray(x, dtype=float) - e
            if g.size > 0:
                g[:] = E

        opt.add_equality_mconstraint(equalities, [CTOL] * len(e))
    if grad is None and initial_step is not None:
        opt.set_initial_step(np.asarray(initial_step, dtype=float))
    elif grad is None:
        # COBYLA's first simplex: a tenth of each parameter's size, not of its (wide) bounds.
        opt.set_initial_step(np.maximum(0.1 * np.abs(np.asarray(x0, dtype=float)), 1e-3 * (ub - lb)))
    opt.set_xtol_rel(xtol_rel)
    opt.set_ftol_rel(ftol_rel)
    opt.set_maxeval(int(maxeval))
    x_start = np.clip(np.asarray(x0, dtype=float), lb, ub)
    try:
        x = np.asarray(opt.optimize(x_start), dtype=float)
        status = _STATUS.get(opt.last_optimize_result(), str(opt.last_optimize_result()))
    except nlopt.RoundoffLimited:
        x, status = best["x"], "roundoff_limited"
    except nlopt.ForcedStop:
        x, status = best["x"], "forced_stop"
    except nlopt.runtime_error:
        # NLOPT_FAILURE, which SLSQP returns when its least-squares subproblem breaks down (for
        # example near a degenerate active set): keep the best feasible point seen, and let the
        # caller judge it by ``status`` and ``feasible``.
        x, status = best["x"], "failure"
    if x is None:
        x = x_start
    if not feasible(x):  # COBYLA may end marginally outside the constraints
        if best["x"] is not None:
            x = best["x"]
        elif project is not None:
            x = project(x)
    f = float(fun(x))
    if best["x"] is not None and best["f"] < f:
        x, f = best["x"], best["f"]
    return Outcome(x=x, f=f, status=status, n_eval=best["n"], feasible=feasible(x))
