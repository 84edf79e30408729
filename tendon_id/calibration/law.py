"""Constrained calibration of the snake chain's capstan law with nlopt (:doc:`/guide/calibration`).

The friction law is fitted by least squares in the log domain on terminal-only
labels, ``sum_t sum_i (ln T_hat[N, N, i] - ln T[N, N, i])^2``, under
``mu_i(alpha) >= 0`` on ``[0, pi]``, which for the affine-cosine law is
``B >= |A|`` (two linear constraints per guide and tendon;
:class:`~tendon_id.calibration.law_layout.LawLayout`).  :func:`calibrate` consumes the
:class:`~tendon_id.calibration.problem.LawProblem` and returns a :class:`CalibrationResult`.

* Smooth models: ``ln T_N`` is linear in ``(A, B)`` (the problem's
  :attr:`~tendon_id.calibration.problem.LawProblem.design`), so the objective is a quadratic built
  once from ``X^T X``; nlopt's SLSQP gets its exact gradient.  The robot's geometry (the
  routing wrap, the clearance), which a smooth model fits too, is profiled out first
  (:mod:`tendon_id.calibration.law_geometry`).
* Nonsmooth models (hysteresis, lags, free block parameters): COBYLA, started
  from the best point of a coarse constant-mu scan, from the smooth solution and
  from random feasible points (multi-start); the geometry jointly with the law and the
  other block parameters, from its profile on the model's smooth part.

A caveat of the nonsmooth fit: the model's play operator is driven by the
*measured* actuator tension, and a play operator ratchets on input noise (each
noise spike can drag a sticking output along), so with load-cell noise the fitted
``mu`` is biased upwards (about 1–4 % at 1 N noise on 100–250 N tensions in our
tests, under 0.5 % at 0.05 N).  The smooth models have no such bias.

nlopt is called through :func:`tendon_id.calibration.optimize.minimize`, which wraps it defensively.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration.law_geometry import forward_slip, law_fits, profile_geometry
from tendon_id.calibration.law_layout import MU_MAX, R_MIN, LawLayout
from tendon_id.calibration.optimize import CTOL, Outcome, minimize
from tendon_id.calibration.problem import LawProblem
from tendon_id.errors import ConfigError, TendonIdError

# Re-exported: calibration's documented API before the problem object had modules of its own.
__all__ = [
    "CTOL",
    "MU_MAX",
    "R_MIN",
    "CalibrationError",
    "CalibrationResult",
    "LawLayout",
    "Outcome",
    "calibrate",
    "calibrate_capstan",
    "linear_design",
    "minimize",
]

#: Relative objective tolerance of the derivative-free fits: the sum of squared log errors
#: of a nonsmooth model is piecewise smooth, and changes below this are rounding, not fit.
NONSMOOTH_FTOL = 1e-5
#: Coarse grid of mu(0) scanned before a nonsmooth fit (the terminal data pins mu(0) best).
MU0_GRID = np.geomspace(0.02, 1.5, 16)


class CalibrationError(TendonIdError, RuntimeError):
    """The optimiser found no usable point."""


@dataclass
class CalibrationResult:
    """Outcome of :func:`calibrate`.

    Attributes
    ----------
    A, B : ndarray, shape (G, n)
        Fitted law (``B`` is mu for the constant law, ``A`` zero) [-].
    block_values : dict
        Fitted free block parameters.
    loss : float
        Mean squared log error per frame and tendon at the optimum [-].
    status : list of str
        nlopt's stop reason per optimisation (per tendon, or joint).
    n_eval : int
        Objective evaluations in all.
    starts : int
        Starts per optimisation.
    seconds : float
        Wall time [s].
    """

    A: NDArray[np.float64]
    B: NDArray[np.float64]
    block_values: dict = field(default_factory=dict)
    loss: float = float("nan")
    status: list = field(default_factory=list)
    n_eval: int = 0
    starts: int = 1
    seconds: float = 0.0

    def to_dict(self) -> dict:
        """``{"loss", "status", "n_eval", "starts", "seconds"}`` (the model's ``calibration_``)."""
        return {
            "loss": self.loss,
            "status": self.status,
            "n_eval": self.n_eval,
            "starts": self.starts,
            "seconds": self.seconds,
        }


def linear_design(model, inputs) -> tuple[NDArray, NDArray]:
    """``(X, Y)``: the design and log-drops of ``model``'s law problem on ``inputs``.

    The problem is :class:`~tendon_id.calibration.problem.LawProblem`.

    ``ln T[1, N, i] - ln T[N, N, i] = X theta_i`` for the smooth models; see
    :attr:`LawProblem.design <tendon_id.calibration.problem.LawProblem.design>` and
    :attr:`~tendon_id.calibration.problem.LawProblem.log_drop`.

    Parameters
    ----------
    model : CapstanModel
    inputs : TransmissionInputs
    """
    problem = LawProblem.from_model(model, inputs)
    return problem.design, problem.log_drop


def _starts(
    sse: Callable[[NDArray], float],
    layout: LawLayout,
    smooth: NDArray,
    rng: np.random.Generator,
    n: int,
    smooth_first: bool = False,
) -> list[NDArray]:
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


def _fit_per_tendon(problem: LawProblem, smooth: NDArray, rng: np.random.Generator) -> tuple[NDArray, list, int, float]:
    """Nonsmooth law without free block parameters: the tendons are independent, so each is fitted on its own.

    Multi-start COBYLA in the free box coordinates ``(mu0, r)``.  Returns the law (p, n) for n tendons per set, the
    stop reasons, the evaluations and the summed squared log error.
    """
    model, inputs, layout, keep, values = problem.model, problem.inputs, problem.layout, problem.keep, problem.values
    theta = smooth.copy()
    status, n_eval, sse_sum = [], 0, 0.0
    kept = slice(None) if keep.all() else keep  # a slice is a view: no copy per evaluation
    log_label = np.log(inputs.terminal)
    last = np.array([inputs.n_modules - 1])
    zlb, zub = layout.free_bounds()
    smooth_first = not any(b.stage == "propagate" for b in model.block_objects)
    for i in range(inputs.n_tendons):
        # Fixed: no free block parameters, so the law-free part of the exponent is computed once.
        terms = model.exponent_terms(inputs, values, sets=last, tendons=np.array([i]))

        def sse(x, i=i, terms=terms, label=log_label[kept, i]):
            A, B = layout.split(x)
            pred = problem.terminal_reading(A[:, None], B[:, None], tendons=np.array([i]), terms=terms)[:, 0]
            # Written as before the compiled scan: the optimiser's path depends on the last bits.
            return float(np.sum((np.log(pred[kept]) - label) ** 2))

        x_starts = _starts(sse, layout, theta[:, i], rng, int(model.n_starts), smooth_first=smooth_first)
        outs = [
            minimize(
                lambda z: sse(layout.from_free(z)),
                layout.to_free(x),
                lb=zlb,
                ub=zub,
                xtol_rel=model.xtol_rel,
                ftol_rel=NONSMOOTH_FTOL,
                maxeval=model.maxeval,
            )
            for x in x_starts
        ]
        best = min(outs, key=lambda o: o.f)
        theta[:, i] = layout.from_free(best.x)
        status.append(best.status)
        n_eval += sum(o.n_eval for o in outs)
        sse_sum += best.f
    return theta, status, n_eval, sse_sum


def _fit_joint(problem: LawProblem, rng: np.random.Generator) -> tuple[NDArray, dict, str, int, float]:
    """Free block parameters couple the tendons: one joint fit of every law and the block parameters.

    The laws are fitted in the free box coordinates, the block parameters within their
    bounds.  Returns the law (p, n), the block values, the stop reason, the evaluations
    (the base fit's included) and the squared log error.
    """
    model, inputs, layout, keep = problem.model, problem.inputs, problem.layout, problem.keep
    free = model.free_parameters()
    p, m = layout.size, inputs.n_tendons  # law parameters per tendon, tendons per set
    names = [(b, q) for b, q, _, _ in free]
    blo = np.array([bd[0] for _, _, bd, _ in free])
    bhi = np.array([bd[1] for _, _, bd, _ in free])
    zlb, zub = layout.free_bounds()
    kept = slice(None) if keep.all() else keep  # a slice is a view: no copy per evaluation
    label = np.log(inputs.terminal)[kept]

    def unpack(z):
        th = np.stack([layout.from_free(z[i * p : (i + 1) * p]) for i in range(m)], axis=1)  # (p, m)
        vals = {k: dict(v) for k, v in problem.values.items()}
        for (bn, q), v in zip(names, z[m * p :]):
            vals[bn][q] = float(v)
        A, B = layout.split(th)
        return A, B, vals

    def sse(z):
        A, B, vals = unpack(z)
        # The residual made in the logarithm's own array: the bits of sum((log(pred) - label) ** 2),
        # without its three more arrays of the recording's length at every evaluation.
        r = np.log(problem.terminal_reading(A, B, vals)[kept])
        r -= label
        return float(np.sum(np.square(r, out=r)))

    # Stage 0: where the geometry (routing wrap, clearance) may start: where the blocks start (what
    # the user gave), the profile of the smooth part, and with stick/slip its profile on the frames
    # in forward slip.  Stage 1: the law alone at each, every block held (the other blocks at their
    # initial, neutral, values), by the cheaper per-tendon route.  The joint fit starts from the
    # best of these base fits.
    base = model.with_blocks()
    base.blocks = tuple(dataclasses.replace(b, fixed=True) for b in base.block_objects)
    starts, geo_evals = [problem.values], 0
    stick_slip = any(b.stage == "propagate" for b in model.block_objects)
    for surrogate in (problem, forward_slip(problem) if stick_slip else None):
        if surrogate is not None and model.geometric_parameters():
            values, evals = profile_geometry(surrogate)
            starts.append(values)
            geo_evals += evals
    fits = [calibrate(LawProblem.from_model(base, inputs, values=v)) for v in starts]
    k = min(range(len(fits)), key=lambda i: fits[i].loss)  # the first of equal losses: the user's start
    start_values, base_fit = starts[k], fits[k]
    geo_evals += sum(f.n_eval for f in fits) - base_fit.n_eval
    b0 = np.array([start_values[b][q] for b, q in names])
    theta = np.stack([layout.join(base_fit.A[:, i], base_fit.B[:, i]) for i in range(m)], axis=1)
    starts = int(model.n_starts)

    def free0(th):
        return np.concatenate([layout.to_free(th[:, i]) for i in range(m)])

    g = layout.n_groups
    scan = [np.r_[free0(np.tile(layout.join(np.zeros(g), np.full(g, mu))[:, None], m)), b0] for mu in MU0_GRID]
    scan_start = min(scan, key=sse)
    # The smooth law with the blocks at their initial (usually neutral) values comes first:
    # the augmented model then starts from the base model's fit and can only improve on it.
    z_starts = [np.r_[free0(theta), b0], scan_start]
    if len(free) == len(model.geometric_parameters()):
        # Only the geometry is free: the base fits above explored the law from every start of their
        # own, at every candidate geometry, so the joint fit only polishes the best of them.
        z_starts, starts = z_starts[:1], 1
    while len(z_starts) < starts:
        around = [layout.from_free(scan_start[i * p : (i + 1) * p]) for i in range(m)]
        law = np.stack([layout.random_feasible(rng, around[i]) for i in range(m)], axis=1)
        z_starts.append(np.r_[free0(law), rng.uniform(blo, bhi)])
    # COBYLA's trust region only shrinks from its first step: a block parameter starting at its
    # neutral 0 steps by its typical magnitude (the block's probe), not by a thousandth of its range.
    # The geometry's start comes from its profile, so it keeps the default step.
    probes = {b.name: b.probe for b in model.block_objects if not b.geometric}
    typical = np.array([_typical(probes.get(bn, {}).get(q)) for bn, q in names], dtype=float).reshape(-1)
    typical = np.minimum(typical, 0.25 * (bhi - blo))  # 0 where the block gives none
    lb, ub = np.r_[np.tile(zlb, m), blo], np.r_[np.tile(zub, m), bhi]

    def first_step(z):
        step = np.maximum(0.1 * np.abs(z), 1e-3 * (ub - lb))  # minimize's default
        step[m * p :] = np.maximum(step[m * p :], typical)
        return step

    outs = [
        minimize(
            sse,
            z,
            lb=lb,
            ub=ub,
            xtol_rel=model.xtol_rel,
            ftol_rel=NONSMOOTH_FTOL,
            maxeval=model.maxeval * 3,
            initial_step=first_step(z),
        )
        for z in z_starts[:starts]
    ]
    best = min(outs, key=lambda o: o.f)
    A, B, vals = unpack(best.x)
    theta = np.stack([layout.join(A[:, i], B[:, i]) for i in range(m)], axis=1)
    return theta, vals, best.status, geo_evals + base_fit.n_eval + sum(o.n_eval for o in outs), best.f


def _typical(probe) -> float:
    """A block parameter's typical magnitude from its probe (a number, or several time scales), else 0."""
    if probe is None:
        return 0.0
    return float(np.max(np.abs(np.atleast_1d(np.asarray(probe, dtype=float)))))


def calibrate(problem: LawProblem) -> CalibrationResult:
    """Fit the law (and the free block parameters) of ``problem.model`` on its terminal labels.

    See the module docstring: SLSQP on the exact quadratic for smooth models, multi-start
    COBYLA for nonsmooth ones (per tendon, or jointly with free block parameters).  Only the
    frames in ``problem.keep`` count.

    Raises
    ------
    ConfigError
        If the model's warm-up leaves no frame.
    CalibrationError
        If the law ends outside the feasible set (a bug).
    """
    t0 = time.perf_counter()
    model, layout, keep = problem.model, problem.layout, problem.keep
    if not keep.any():
        raise ConfigError(f"warmup_s={model.warmup_s} leaves no frame to calibrate on")
    free = model.free_parameters()
    n_eval = 0
    if model.is_smooth and free:  # only geometric parameters are free: profile them, the law is exact at them
        values, n_eval = profile_geometry(problem)
        problem = problem.with_values(values)
    smooth = law_fits(problem)
    status = [o.status for o in smooth]
    n_eval += sum(o.n_eval for o in smooth)
    theta = np.stack([o.x for o in smooth], axis=1)  # (p, n): one law per tendon
    m = theta.shape[1]
    n_obs = int(keep.sum()) * m
    values = problem.values
    rng = np.random.default_rng(model.seed)

    if model.is_smooth:
        loss = sum(o.f for o in smooth) / n_obs
        starts = 1
    elif not free:
        theta, more, evals, sse_sum = _fit_per_tendon(problem, theta, rng)
        status += more
        n_eval += evals
        loss, starts = sse_sum / n_obs, int(model.n_starts)
    else:
        # The joint fit reads the forward model, never the design: let go of it (a third of a snake's
        # recording) while the base fits the joint fit starts from build their own.
        problem = problem.without_design()
        theta, values, stop, evals, sse_sum = _fit_joint(problem, rng)
        status.append(stop)
        n_eval += evals
        loss, starts = sse_sum / n_obs, int(model.n_starts)

    A = np.stack([layout.split(theta[:, i])[0] for i in range(m)], axis=1)
    B = np.stack([layout.split(theta[:, i])[1] for i in range(m)], axis=1)
    if model.mu_law == "affine-cosine":
        # Optimisers stop within CTOL of the edge B = |A|; land exactly on the feasible side.
        B = np.maximum(B, np.abs(A))
    if not all(layout.feasible(layout.join(A[:, i], B[:, i]), CTOL) for i in range(m)):
        raise CalibrationError("calibration ended outside the feasible set B >= |A|; this is a bug, please report it")
    block_values: dict[str, dict[str, float]] = {}
    for b, q, _, _ in free:
        block_values.setdefault(b, {})[q] = float(values[b][q])
    return CalibrationResult(
        A=A,
        B=B,
        block_values=block_values,
        loss=float(loss),
        status=status,
        n_eval=n_eval,
        starts=starts,
        seconds=time.perf_counter() - t0,
    )


def calibrate_capstan(model, inputs) -> CalibrationResult:
    """Fit a :class:`~tendon_id.zoo.capstan.CapstanModel` on terminal labels: :func:`calibrate` of its problem.

    Parameters
    ----------
    model : CapstanModel
        Its structure and settings are read; the caller stores the result (``CapstanModel.fit``).
    inputs : TransmissionInputs
    """
    return calibrate(LawProblem.from_model(model, inputs))
