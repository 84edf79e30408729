"""The robot's geometry fitted with the law: the routing wrap and the clearance, profiled (:doc:`/guide/calibration`).

A user does not know the routing wrap ``alpha_0`` nor the clearance ``alpha_c`` of a robot, so
the capstan models fit them (:mod:`tendon_id.zoo.blocks.geometric`).  At any fixed value of
them a smooth model's terminal log-drop is linear in the law
(:attr:`~tendon_id.calibration.problem.LawProblem.design`), whose constrained least squares
have an exact solution, so the geometric parameters ``g`` are fitted on the profile

    loss(g) = sum_i min_{law_i feasible} sum_t (ln T[1, N, i] - ln T[N, N, i] - X(g) theta_i)^2,

the separable least squares of Golub & Pereyra (1973, "The differentiation of pseudo-inverses
and nonlinear least squares problems whose variables separate", SIAM J. Numer. Anal. 10(2),
413-432): two dimensions searched instead of eight.  The profile is not convex (with the
paper's hard gate it is piecewise constant in ``alpha_c``, with a valley about as wide as the
spread of the wraps near the clearance), so it is scanned on a grid first: the routing wrap
on :data:`ROUTING_GRID` points of its bounds, and for each the clearance every
:data:`CLEARANCE_STEP` in phase with it (a clearance acts on the wrap the routing gives, so
what the gate sees is ``alpha_c - alpha_0``).  Of the grid's points that the data cannot tell
from its best (the profile likelihood's 95 % region), the one nearest the start is kept: with
the dead zone only ``alpha_c - alpha_0`` shows in the data, a ridge along which any point fits
as well, and the start is what the user gave; this is the one-standard-error rule's choice of
the simplest of the fits the data cannot tell apart (Hastie, Tibshirani & Friedman 2009, "The
Elements of Statistical Learning", 2nd ed., section 7.10).  COBYLA then refines it within its
grid cell.  The law of the profile
is the tied one: the geometry is the robot's, one for every guide, and a per-guide law is not
identifiable from terminal labels (:doc:`/guide/zoo`), so its profile would trade the geometry
against single guides' laws, at twenty times the cost.

For a nonsmooth model the profile of its smooth part (its law with the routing and
tendon-independent exponent blocks, :meth:`~tendon_id.zoo.capstan.CapstanModel.smooth_part`)
starts the joint fit (:mod:`tendon_id.calibration.law`).  The smooth part is forward slip at
every guide, which frames near a reversal of the tension are not (the play operator holds
them inside its band, or slips them backwards), so its profile is also taken on the frames
in forward slip alone (:func:`forward_slip`), and the joint fit starts from whichever of the
two its model fits better.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
from numpy.typing import NDArray

from friction_models import play_operator
from tendon_id.calibration.law_layout import LawLayout
from tendon_id.calibration.optimize import Outcome, minimize
from tendon_id.calibration.problem import LawProblem, constrained_lstsq, guide_design

__all__ = ["CLEARANCE_STEP", "ROUTING_GRID", "TiedLeastSquares", "forward_slip", "law_fits", "profile_geometry"]

#: Grid points of the routing wrap over its bounds (7: every 0.05 rad on [0, 0.3] rad).
ROUTING_GRID = 7
#: Grid step of the clearance beyond the routing wrap [rad]: below the width of the hard gate's
#: valley on the paper's protocols (about 0.02 rad).
CLEARANCE_STEP = 0.01
#: Relative tolerance of the refinement: 1e-4 of a clearance of 0.1 rad is 1e-5 rad, far below
#: what terminal data resolve.
XTOL_REL = 1e-4
#: Profile evaluations of the refinement, per geometric parameter.
MAXEVAL_PER_PARAM = 60
#: Level of the profile likelihood region whose point nearest the start is refined.
CONFIDENCE = 0.95
#: Fewest frames in forward slip worth a profile of their own.
MIN_SLIP_FRAMES = 20


def law_fits(problem: LawProblem) -> list[Outcome]:
    """Each tendon's constrained least-squares law on ``problem``'s design and kept frames (the smooth fit)."""
    X, Y, keep = problem.design, problem.log_drop, problem.keep
    return [constrained_lstsq(X[keep], Y[keep, i], problem.layout, 1e-10) for i in range(Y.shape[1])]


class TiedLeastSquares:
    """``min |y - X x|^2`` over a tied law's feasible set, exactly, for every tendon at once.

    The feasible set of a tied law (one or two parameters) is an interval or a polygon
    (:class:`~tendon_id.calibration.law_layout.LawLayout`), so the minimum of the convex
    quadratic lies at the unconstrained minimum, on an edge or at a vertex: every candidate is
    computed and the best feasible one kept.  The edges and vertices do not depend on the
    data, so they are computed once; a call costs two small matrix products where SLSQP,
    which the profile would call hundreds of times per fit, costs hundreds.

    Parameters
    ----------
    layout : LawLayout
        A tied law's (``n_groups == 1``).
    """

    def __init__(self, layout: LawLayout):
        self.layout = layout
        lb, ub = layout.bounds()
        if layout.size == 1:  # the constant law: mu in [lb, ub]
            self.C, self.d = np.array([[1.0], [-1.0]]), np.r_[ub, -lb]
            self.vertices = np.array([lb, ub])
        else:
            self.C, self.d = layout.constraints()
            pairs = [(i, j) for i, j in itertools.combinations(range(len(self.d)), 2)]
            pairs = [(i, j) for i, j in pairs if abs(np.linalg.det(self.C[[i, j]])) > 1e-12]
            self.vertices = np.array([np.linalg.solve(self.C[[i, j]], self.d[[i, j]]) for i, j in pairs])
        # Each edge's line a.x = e as x0 + t v, v along the line (two parameters; one has no edges).
        lines = zip(self.C, self.d) if layout.size == 2 else ()
        self.lines = [(a * e / float(a @ a), np.array([-a[1], a[0]])) for a, e in lines]
        self.tol = 1e-12 * (1.0 + np.abs(self.d))

    def sse(self, X: NDArray, Y: NDArray) -> NDArray:
        """The least sum of squares of each column of ``Y`` (T, m) on ``X`` (T, p) over the feasible set, shape (m,)."""
        M, b, c = X.T @ X, X.T @ Y, np.einsum("tm,tm->m", Y, Y)  # (p, p), (p, m), (m,)
        cands = [np.broadcast_to(v[:, None], b.shape) for v in self.vertices]
        if abs(np.linalg.det(M)) > 1e-300:
            cands.append(np.linalg.solve(M, b))
        for x0, v in self.lines:
            curv = float(v @ M @ v)
            if curv > 0:
                cands.append(x0[:, None] + v[:, None] * ((v @ (b - (M @ x0)[:, None])) / curv)[None, :])
        x = np.stack(cands)  # (n, p, m)
        f = c[None, :] - 2.0 * np.einsum("npm,pm->nm", x, b) + np.einsum("npm,pq,nqm->nm", x, M, x)
        feasible = np.all(np.einsum("kp,npm->nkm", self.C, x) <= (self.d + self.tol)[None, :, None], axis=1)
        return np.min(np.where(feasible, f, np.inf), axis=0)


def profile_geometry(problem: LawProblem) -> tuple[dict, int]:
    """The model's free geometric parameters at the minimum of the profiled loss (see the module docstring).

    Parameters
    ----------
    problem : LawProblem
        Built from the model whose geometric parameters are fitted; its ``values`` hold every
        other block parameter where it stays, and its ``keep`` the frames that count.

    Returns
    -------
    values : dict
        ``problem.values`` with the geometric parameters at the profile's minimum.
    n_eval : int
        Evaluations of the profile.
    """
    model = problem.model
    free = model.geometric_parameters()
    if not free:
        return problem.values, 0
    smooth = model.smooth_part()  # the model itself when smooth; nonsmooth: the start's surrogate
    names = [(b, q) for b, q, _, _ in free]
    lb = np.array([bd[0] for _, _, bd, _ in free], dtype=float)
    ub = np.array([bd[1] for _, _, bd, _ in free], dtype=float)
    start = np.clip([v for *_, v in free], lb, ub)
    routing = {b.name for b in model.block_objects if b.stage == "routing"}
    count = {"n": 0}

    def at(x) -> dict:
        vals = {k: dict(v) for k, v in problem.values.items()}
        for (b, q), v in zip(names, x):
            vals.setdefault(b, {})[q] = float(v)
        return vals

    exact = TiedLeastSquares(LawLayout(model.mu_law, 1))
    # The problem's labels with the tied law: only the design moves with the geometry (made in loss), so
    # the template takes the problem's arrays, not a design of its own (a third of a snake's recording).
    tied = LawProblem(
        problem.guide_design, problem.log_drop, problem.weight, "tied", problem.inputs, smooth.mu_law,
        problem.noise_n, problem.keep, smooth, problem.values,
    )  # fmt: skip
    keep, log_drop = problem.keep, tied.log_drop[problem.keep]  # the smooth part has no warm-up of its own

    def loss(x) -> float:
        count["n"] += 1
        # Only the design moves with the geometry: the labels, weights and frames are the problem's.
        design = dataclasses.replace(tied, guide_design=guide_design(smooth, problem.inputs, at(x))).design
        return float(np.sum(exact.sse(design[keep], log_drop)))

    grid = _grid(names, routing, problem.values, lb, ub, start)
    scores = np.array([loss(x) for x in grid])
    # The points the data cannot tell from the best: within the profile likelihood's 95 % region,
    # -2 ln L = SSE / sigma^2 with sigma^2 the best point's residual variance (Wilks).  Of those,
    # the one nearest the start: the data leave a ridge where the dead zone trades the clearance
    # against the routing wrap (only alpha_c - alpha_0 shows), and the start is what the user gave.
    from scipy.stats import chi2  # here: importing the zoo need not load scipy.stats

    sigma2 = max(scores.min(), 1e-300) / (3 * int(np.sum(problem.keep)))
    close = np.flatnonzero(scores <= scores.min() + chi2.ppf(CONFIDENCE, len(free)) * sigma2)
    span = ub - lb
    best = grid[min(close, key=lambda k: (float(np.sum(((grid[k] - start) / span) ** 2)), k))]
    grid_step = [span[i] / (ROUTING_GRID - 1) if b in routing else CLEARANCE_STEP for i, (b, _) in enumerate(names)]
    cell = 0.5 * np.array(grid_step)
    # Refined within its grid cell: along a ridge the refinement would slide back to an end.
    lo, hi = np.maximum(lb, best - cell), np.minimum(ub, best + cell)
    out = minimize(
        loss,
        best,
        lb=lo,
        ub=hi,
        xtol_rel=XTOL_REL,
        ftol_rel=1e-12,
        maxeval=MAXEVAL_PER_PARAM * len(free),
        initial_step=0.5 * cell,
    )
    x = out.x if out.f <= loss(best) else best
    return at(x), count["n"]


def forward_slip(problem: LawProblem) -> LawProblem | None:
    """``problem`` counting only its frames in forward slip, or None when fewer than :data:`MIN_SLIP_FRAMES`.

    A frame is in forward slip when the terminal set's actuator tension has risen, since its last
    reversal, by more than the chain's band, for every tendon: a play operator on ``ln T[1, N, i]``
    (:func:`friction_models.play_operator`) with the median measured log-drop as its band, the
    drop of a chain in forward slip, is on its forward-slip edge (``sigma = +1``).
    """
    inputs = problem.inputs
    band = np.maximum(np.median(problem.log_drop, axis=0), 1e-3)
    rising = play_operator(np.log(inputs.actuator[:, -1]), band, inputs.reset).sigma == 1
    keep = problem.keep & np.all(rising, axis=1)
    return dataclasses.replace(problem, keep=keep) if keep.sum() >= MIN_SLIP_FRAMES else None


def _grid(names, routing: set, values: dict, lb: NDArray, ub: NDArray, start: NDArray) -> list[NDArray]:
    """The scan's points: the routing wrap on its grid (or where it is held), every other parameter
    every :data:`CLEARANCE_STEP` from it, over its bounds; the starting point first."""
    r_idx = [i for i, (b, _) in enumerate(names) if b in routing]
    o_idx = [i for i, (b, _) in enumerate(names) if b not in routing]
    if r_idx:
        i = r_idx[0]
        routing_wraps = np.union1d(np.linspace(lb[i], ub[i], ROUTING_GRID), [start[i]])
    else:  # held: its value in the problem's block parameters
        routing_wraps = [float(v) for b in routing for v in values.get(b, {}).values()][:1] or [0.0]
    # Below the routing wrap too: a clearance of 0 is a tendon always in contact (the plain capstan).
    width = float(np.max(ub - lb))
    offsets = np.arange(-width, width + CLEARANCE_STEP / 2, CLEARANCE_STEP)
    points = [start.copy()]
    for a0 in routing_wraps:
        axes = [np.unique(np.clip(a0 + offsets, lb[i], ub[i])) for i in o_idx]
        for rest in itertools.product(*axes):
            x = np.empty(len(names))
            x[r_idx] = a0
            x[o_idx] = rest
            points.append(x)
    return points
