"""The nlopt wrapper: a solver failure returns the best feasible point seen, with its status, never raises."""

import nlopt
import numpy as np

from tendon_id.calibration import optimize


def test_an_slsqp_failure_returns_the_best_feasible_point_with_status_failure(monkeypatch):
    # SLSQP raises NLOPT_FAILURE (nlopt.runtime_error) when its least-squares subproblem breaks
    # down; the profile likelihoods of the identifiability report met it on elastic-tendon data.
    real = nlopt.opt

    class Failing:
        def __init__(self, *args):
            self._opt = real(*args)

        def __getattr__(self, name):
            return getattr(self._opt, name)

        def optimize(self, x):
            f = self._opt.optimize  # evaluate a few points first, so a best one exists
            self._opt.set_maxeval(3)
            f(x)
            raise nlopt.runtime_error("nlopt failure")

    monkeypatch.setattr(optimize.nlopt, "opt", Failing)
    fun = lambda x: float((x[0] - 1.0) ** 2 + (x[1] + 2.0) ** 2)  # noqa: E731
    grad = lambda x: np.array([2 * (x[0] - 1.0), 2 * (x[1] + 2.0)])  # noqa: E731
    out = optimize.minimize(fun, np.array([0.5, 0.5]), lb=[-5, -5], ub=[5, 5], grad=grad)
    assert out.status == "failure"
    assert out.feasible and np.isfinite(out.f)
    assert out.f <= fun(np.array([0.5, 0.5]))  # the best point seen, never worse than the start


def test_a_failure_with_no_feasible_point_says_so():
    # an equality no point in the box satisfies: the outcome is marked infeasible, not raised
    fun = lambda x: float(x @ x)  # noqa: E731
    grad = lambda x: 2 * x  # noqa: E731
    out = optimize.minimize(
        fun, np.array([0.0, 0.0]), lb=[0, 0], ub=[1, 1], grad=grad, eq=(np.array([[1.0, 1.0]]), np.array([5.0]))
    )
    assert not out.feasible
