"""Constrained calibration of the capstan family with nlopt (DESIGN §7).

The friction law is fitted by least squares in the log domain on terminal-only
labels, ``sum_t sum_i (ln T_hat[N, N, i] - ln T[N, N, i])^2``, under
``mu_i(alpha) >= 0`` on ``[0, pi]``, which for the affine-cosine law is
``B >= |A|`` (two linear constraints per guide and tendon).

* Smooth models: ``ln T_N`` is linear in ``(A, B)``, so the objective is a
  quadratic built once from ``X^T X``; nlopt's SLSQP gets its exact gradient.
* Nonsmooth models (hysteresis, lags, free block parameters): COBYLA, started
  from the best point of a coarse constant-mu scan, from the smooth solution and
  from random feasible points (multi-start).

A caveat of the nonsmooth fit: the model's play operator is driven by the
*measured* actuator tension, and a play operator ratchets on input noise (each
noise spike can drag a sticking output along), so with load-cell noise the fitted
``mu`` is biased upwards (about 1–4 % at 1 N noise on 100–250 N tensions in our
tests, under 0.5 % at 0.05 N).  The smooth models have no such bias.

nlopt is wrapped defensively: tolerances are set, the best feasible point seen
is kept when nlopt stops on ``RoundoffLimited`` or ``ForcedStop``, feasibility
is checked after COBYLA (and restored by projection), and callbacks return
plain floats.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import nlopt
import numpy as np
from numpy.typing import NDArray

from tendon_id.errors import TendonIdError

#: Upper bound on mu(0) = A + B [-]; no tendon–guide pair comes near it.
MU_MAX = 2.0
#: Lower bound on r = 2 A / mu(0): A may be as negative as 10 mu(0) (mu rising 21-fold by pi).
R_MIN = -20.0
#: Constraint tolerance for feasibility checks.
CTOL = 1e-9
#: Relative objective tolerance of the derivative-free fits: the sum of squared log errors
#: of a nonsmooth model is piecewise smooth, and changes below this are rounding, not fit.
NONSMOOTH_FTOL = 1e-5

_STATUS = {
    nlopt.SUCCESS: "success",
    nlopt.STOPVAL_REACHED: "stopval_reached",
    nlopt.FTOL_REACHED: "ftol_reached",
    nlopt.XTOL_REACHED: "xtol_reached",
    nlopt.MAXEVAL_REACHED: "maxeval_reached",
    nlopt.MAXTIME_REACHED: "maxtime_reached",
}


class CalibrationError(TendonIdError, RuntimeError):
    """The optimiser found no usable point."""


@dataclass
class Outcome:
    """Result of one :func:`minimize` call."""

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
) -> Outcome:
    """Minimise ``fun`` under ``lb <= x <= ub`` and ``ineq(x) <= 0`` with nlopt.

    Uses ``LD_SLSQP`` when ``grad`` is given (``ineq`` must then be linear with
    Jacobian ``ineq_jac``), else ``LN_COBYLA``.

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
    """
    n = len(x0)
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
        f = float(fun(x))
        best["n"] += 1
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
        E, e = np.atleast_2d(np.asarray(eq[0], dtype=float)), np.atleast_1d(np.asarray(eq[1], dtype=float))

        def equalities(result, x, g):
            result[:] = E @ np.asarray(x, dtype=float) - e
            if g.size > 0:
                g[:] = E

        opt.add_equality_mconstraint(equalities, [CTOL] * len(e))
    if grad is None:
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


# ---- the capstan law's parameter vector ----------------------------------------------------


@dataclass
class LawLayout:
    """Per-tendon parameter vector ``[A_1..A_G, B_1..B_G]`` (affine-cosine) or ``[mu_1..mu_G]``.

    The feasible set of a group is ``B >= |A|`` (``mu >= 0`` on ``[0, pi]``), with the
    sanity limits ``mu(0) = A + B <= MU_MAX`` and ``A >= R_MIN mu(0) / 2``.  Derivative-free
    fits work in the free coordinates ``(mu0, r)`` with ``A = r mu0 / 2`` and
    ``B = mu0 - A``: every point of the box ``0 <= mu0 <= MU_MAX``, ``R_MIN <= r <= 1``
    is feasible, so COBYLA needs no constraint and ``mu0``, the best-determined
    combination, is a coordinate.
    """

    mu_law: str
    n_groups: int

    @property
    def size(self) -> int:
        return self.n_groups * (2 if self.mu_law == "affine-cosine" else 1)

    def split(self, x: NDArray) -> tuple[NDArray, NDArray]:
        g = self.n_groups
        if self.mu_law == "affine-cosine":
            return x[:g], x[g : 2 * g]
        return np.zeros_like(x[:g]), x[:g]

    def join(self, A: NDArray, B: NDArray) -> NDArray:
        return np.concatenate([A, B]) if self.mu_law == "affine-cosine" else np.asarray(B, dtype=float)

    def bounds(self) -> tuple[NDArray, NDArray]:
        g = self.n_groups
        if self.mu_law == "affine-cosine":
            return np.r_[np.full(g, R_MIN * MU_MAX / 2), np.zeros(g)], np.r_[np.full(g, MU_MAX / 2), np.full(g, MU_MAX * (1 - R_MIN / 2))]
        return np.zeros(g), np.full(g, MU_MAX)

    def constraints(self) -> tuple[NDArray, NDArray] | None:
        """Linear constraints ``C x <= d`` of the feasible set (affine-cosine law)."""
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


@dataclass
class CalibrationResult:
    """Outcome of :func:`calibrate_capstan`.

    Attributes
    ----------
    A, B : ndarray, shape (G, 3)
        Fitted law (``B`` is mu for the constant law, ``A`` zero).
    block_values : dict
        Fitted free block parameters.
    loss : float
        Mean squared log error per frame and tendon at the optimum.
    status : list of str
        nlopt's stop reason per optimisation (per tendon, or joint).
    n_eval : int
        Objective evaluations in all.
    starts : int
        Starts per optimisation.
    seconds : float
    """

    A: NDArray[np.float64]
    B: NDArray[np.float64]
    block_values: dict = field(default_factory=dict)
    loss: float = float("nan")
    status: list = field(default_factory=list)
    n_eval: int = 0
    starts: int = 1
    seconds: float = 0.0

    def summary(self) -> dict:
        return {"loss": self.loss, "status": self.status, "n_eval": self.n_eval, "starts": self.starts, "seconds": self.seconds}


def linear_design(model, inputs) -> tuple[NDArray, NDArray]:
    """Design of the smooth model: ``ln T_1 - ln T_N = X theta_i`` per tendon.

    Returns
    -------
    X : ndarray, shape (T, p)
        Columns ``sum_k m alpha cos(alpha)`` then ``sum_k m alpha`` (tied), or one
        pair per guide (per-guide); only the second half for the constant law.
    Y : ndarray, shape (T, 3)
        ``ln T[1, N, i] - ln T[N, N, i]`` from the labels.
    """
    wrap = inputs.wrap
    m = model.exponent_multiplier(inputs)[..., 0]  # (T, N-1)
    ca, a = m * wrap * np.cos(wrap), m * wrap
    if model.tying == "tied":
        ca, a = ca.sum(axis=1, keepdims=True), a.sum(axis=1, keepdims=True)
    X = np.concatenate([ca, a], axis=1) if model.mu_law == "affine-cosine" else a
    Y = np.log(inputs.actuator[:, -1]) - np.log(inputs.terminal)
    return X, Y


def _fit_quadratic(X: NDArray, y: NDArray, layout: LawLayout, xtol_rel: float) -> Outcome:
    """Constrained least squares ``min |y - X x|^2`` with SLSQP on the exact quadratic."""
    M, b, c = X.T @ X, X.T @ y, float(y @ y)
    cons = layout.constraints()
    lb, ub = layout.bounds()
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


#: Coarse grid of mu(0) scanned before a nonsmooth fit (the terminal data pins mu(0) best).
MU0_GRID = np.geomspace(0.02, 1.5, 16)


def _starts(sse: Callable[[NDArray], float], layout: LawLayout, smooth: NDArray, rng: np.random.Generator, n: int,
            smooth_first: bool = False) -> list[NDArray]:
    """Multi-start points: the best of a constant-mu scan, the smooth solution, then random feasible ones.

    With hysteresis the smooth (no-hysteresis) solution can sit far from the optimum, so the
    first start comes from a 16-point scan of a constant ``mu`` (``A = 0``); without it
    (``smooth_first``) the smooth solution is the better first start.
    """
    g = layout.n_groups
    scan = [layout.join(np.zeros(g), np.full(g, mu)) for mu in MU0_GRID]
    best = min(scan, key=sse)
    starts = [smooth, best] if smooth_first else [best, smooth]
    while len(starts) < n:
        starts.append(layout.random_feasible(rng, best))
    return starts[:n]


def calibrate_capstan(model, inputs) -> CalibrationResult:
    """Fit a :class:`~tendon_id.zoo.capstan.CapstanModel` on terminal labels (see the module docstring)."""
    t0 = time.perf_counter()
    n = inputs.n_modules
    layout = LawLayout(model.mu_law, 1 if model.tying == "tied" else n - 1)
    X, Y = linear_design(model, inputs)
    keep = inputs.since_start >= float(model.warmup_s)  # frames that count (see CapstanModel.warmup_s)
    if not keep.any():
        from tendon_id.errors import ConfigError

        raise ConfigError(f"warmup_s={model.warmup_s} leaves no frame to calibrate on")
    smooth = [_fit_quadratic(X[keep], Y[keep, i], layout, 1e-10) for i in range(3)]
    status = [o.status for o in smooth]
    n_eval = sum(o.n_eval for o in smooth)
    theta = np.stack([o.x for o in smooth], axis=1)  # (p, 3)
    n_obs = int(keep.sum()) * 3
    free = model.free_parameters()
    values = model._values()
    log_label = np.log(inputs.terminal)
    rng = np.random.default_rng(model.seed)

    if model.is_smooth:
        loss = sum(o.f for o in smooth) / n_obs
        starts = 1
    elif not free:
        # Tendons are independent: fit each one's law on its own, in the free box coordinates.
        loss, starts = 0.0, int(model.n_starts)
        multiplier = inputs.wrap[..., None] * model.exponent_multiplier(inputs, values)  # fixed: no free block parameters
        zlb, zub = layout.free_bounds()
        for i in range(3):
            def sse(x, i=i):
                A, B = layout.split(x)
                pred = model.terminal_reading(inputs, A[:, None], B[:, None], values, tendons=np.array([i]), multiplier=multiplier)[:, 0]
                return float(np.sum((np.log(pred[keep]) - log_label[keep, i]) ** 2))

            x_starts = _starts(sse, layout, theta[:, i], rng, starts,
                               smooth_first=not any(b.stage == "propagate" for b in model.block_objects))
            outs = [minimize(lambda z: sse(layout.from_free(z)), layout.to_free(x), lb=zlb, ub=zub, xtol_rel=model.xtol_rel,
                             ftol_rel=NONSMOOTH_FTOL, maxeval=model.maxeval) for x in x_starts]
            best = min(outs, key=lambda o: o.f)
            theta[:, i] = layout.from_free(best.x)
            status.append(best.status)
            n_eval += sum(o.n_eval for o in outs)
            loss += best.f
        loss /= n_obs
    else:
        # Free block parameters couple the tendons: one joint fit (law in free box coordinates).
        p = layout.size
        names = [(b, q) for b, q, _, _ in free]
        blo = np.array([bd[0] for _, _, bd, _ in free])
        bhi = np.array([bd[1] for _, _, bd, _ in free])
        b0 = np.array([v for *_, v in free])
        zlb, zub = layout.free_bounds()

        def unpack(z):
            th = np.stack([layout.from_free(z[i * p : (i + 1) * p]) for i in range(3)], axis=1)  # (p, 3)
            vals = {k: dict(v) for k, v in values.items()}
            for (bn, q), v in zip(names, z[3 * p :]):
                vals[bn][q] = float(v)
            A, B = layout.split(th)
            return A, B, vals

        def sse(z):
            A, B, vals = unpack(z)
            pred = model.terminal_reading(inputs, A, B, vals)
            return float(np.sum((np.log(pred[keep]) - log_label[keep]) ** 2))

        # Stage 1: the law alone, with every block held at its initial (neutral) values, by the
        # cheaper per-tendon route.  The joint fit then starts from that base fit.
        base = model.with_blocks()
        base.blocks = tuple(dataclasses.replace(b, fixed=True) for b in base.block_objects)
        base_fit = calibrate_capstan(base, inputs)
        theta = np.stack([layout.join(base_fit.A[:, i], base_fit.B[:, i]) for i in range(3)], axis=1)
        n_eval += base_fit.n_eval
        starts = int(model.n_starts)
        free0 = lambda th3: np.concatenate([layout.to_free(th3[:, i]) for i in range(3)])  # noqa: E731
        scan = [np.r_[free0(np.tile(layout.join(np.zeros(layout.n_groups), np.full(layout.n_groups, mu))[:, None], 3)), b0] for mu in MU0_GRID]
        scan_start = min(scan, key=sse)
        # The smooth law with the blocks at their initial (usually neutral) values comes first:
        # the augmented model then starts from the base model's fit and can only improve on it.
        z_starts = [np.r_[free0(theta), b0], scan_start]
        while len(z_starts) < starts:
            law = np.stack([layout.random_feasible(rng, layout.from_free(scan_start[i * p : (i + 1) * p])) for i in range(3)], axis=1)
            z_starts.append(np.r_[free0(law), rng.uniform(blo, bhi)])
        outs = [minimize(sse, z, lb=np.r_[np.tile(zlb, 3), blo], ub=np.r_[np.tile(zub, 3), bhi], xtol_rel=model.xtol_rel,
                         ftol_rel=NONSMOOTH_FTOL, maxeval=model.maxeval * 3) for z in z_starts[:starts]]
        best = min(outs, key=lambda o: o.f)
        A, B, vals = unpack(best.x)
        theta = np.stack([layout.join(A[:, i], B[:, i]) for i in range(3)], axis=1)
        values = vals
        status.append(best.status)
        n_eval += sum(o.n_eval for o in outs)
        loss = best.f / n_obs

    A = np.stack([layout.split(theta[:, i])[0] for i in range(3)], axis=1)
    B = np.stack([layout.split(theta[:, i])[1] for i in range(3)], axis=1)
    if model.mu_law == "affine-cosine":
        # Optimisers stop within CTOL of the edge B = |A|; land exactly on the feasible side.
        B = np.maximum(B, np.abs(A))
    if not all(layout.feasible(layout.join(A[:, i], B[:, i]), CTOL) for i in range(3)):
        raise CalibrationError("calibration ended outside the feasible set B >= |A|; this is a bug, please report it")
    block_values: dict[str, dict[str, float]] = {}
    for b, q, _, _ in free:
        block_values.setdefault(b, {})[q] = float(values[b][q])
    return CalibrationResult(A=A, B=B, block_values=block_values, loss=float(loss), status=status, n_eval=n_eval,
                             starts=starts, seconds=time.perf_counter() - t0)
