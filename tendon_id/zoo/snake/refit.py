"""The snake chain's refit of a capstan structure from a starting fit, which the diagnosis repeats per candidate.

The refit minimises the calibration's loss, ``sum (ln T_hat[N, N, i] - ln T[N, N, i])^2`` over
the frames after the model's warm-up (:doc:`/guide/calibration`), jointly over every tendon's law and the
free block parameters, with scipy's trust-region reflective least squares (Branch, Coleman
& Li 1999).  It is a local refinement from the base model's fit, not a global search, and
it is a least-squares problem whose Jacobian is block-sparse (tendon ``i``'s law, and its own
block parameters such as its actuator cell's gain, move only tendon ``i``'s residuals:
``Block.param_tendon``), which ``least_squares`` exploits by perturbing the three tendons'
parameters in one evaluation.  A step of a parameter that acts on the terminal reading alone
reuses the chain it steps from (``CapstanModel.sensor_only``).  nlopt's derivative-free methods
cannot use either, and take about ten times as many evaluations here (COBYLA: 3 704
evaluations for one viscoelastic fit on 5 000 frames).  The law is parametrised in the free box coordinates of
:class:`~tendon_id.calibration.law_layout.LawLayout`, so every step is feasible (``B >= |A|``).
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares
from scipy.sparse import lil_matrix

from tendon_id.calibration.law_layout import LawLayout
from tendon_id.errors import ConfigError
from tendon_id.family.fit import Fit
from tendon_id.metrics import jacobian_correlation

__all__ = ["refit"]

#: Relative step of the finite-difference Jacobian: the nonsmooth models (play operator) are
#: piecewise smooth in their parameters, and a step far above rounding averages over kinks.
DIFF_STEP = 1e-4
#: Relative change of the loss, or of the parameters, below which a refit stops.  The Jacobian's
#: steps of ``DIFF_STEP`` over a piecewise-smooth loss resolve the parameters no finer than about
#: that, and a diagnosis compares held-out errors whose bootstrap intervals are far wider.  On
#: ``perf/bench_diagnosis.py`` (5 000 frames of ``snake12-elastic``) 1e-5 against 1e-8 moved every
#: ladder rung's held-out RMSE by 0.02 N at most and took 39 s against 98 s (:doc:`/guide/diagnosis`).
REFIT_TOL = 1e-5
#: Smallest predicted tension [N] whose logarithm the loss takes (a sensor offset may push below 0).
FLOOR_N = 1e-3


def _law_stack(A: NDArray, B: NDArray, layout: LawLayout) -> NDArray:
    return np.concatenate([layout.to_free(layout.join(A[:, i], B[:, i])) for i in range(A.shape[1])])


def refit(
    structure,
    inputs,
    A: NDArray,
    B: NDArray,
    values: dict,
    *,
    max_nfev: int = 60,
    tol: float | None = None,
) -> Fit:
    """Fit ``structure``'s law and free block parameters on ``inputs``, starting from ``(A, B, values)``.

    Parameters
    ----------
    structure : CapstanModel
        The blocks and settings (its ``warmup_s`` decides which frames count).
    inputs : TransmissionInputs
        Training data, with terminal labels.
    A, B : ndarray, shape (G, n)
        Starting law (``n`` tendons per set) (a base model's fit), feasible.
    values : dict
        Starting block parameters ``{block: {param: value}}``; blocks missing here start at
        their own (neutral) values.
    max_nfev : int
        Jacobian evaluations allowed (each costs a few model evaluations).
    tol : float, optional
        Relative change of the cost and the parameters at which the fit stops (``ftol``, ``xtol``);
        default :data:`REFIT_TOL`.

    Returns
    -------
    Fit
        Its parameters: each tendon's law in the free box coordinates of
        :class:`~tendon_id.calibration.law_layout.LawLayout` (``mu0[g]:i`` and ``r[g]:i``, or
        ``mu[g]:i``), then ``block:param``; ``sse`` is the sum of squared log errors [-].
    """
    t0 = time.perf_counter()
    structure = structure.started_from(inputs.geometry)  # a candidate's clearance starts from the robot's sizes
    layout = LawLayout(structure.mu_law, A.shape[0])
    p, m = layout.size, A.shape[1]  # law parameters per tendon, tendons per set
    free = structure.free_parameters()
    start_vals = structure.block_params(values)
    names = [(b, q) for b, q, _, _ in free]
    blo = np.array([bd[0] for _, _, bd, _ in free], dtype=float)
    bhi = np.array([bd[1] for _, _, bd, _ in free], dtype=float)
    # A parameter that starts on its bound (no lag, no viscous friction) is moved 1 % of its range
    # inside: the reflective trust region scales steps by the distance to the bound, so it
    # cannot leave a bound it starts on.
    inset = 0.01 * (bhi - blo)
    b0 = np.clip(np.array([start_vals[b][q] for b, q in names], dtype=float), blo + inset, bhi - inset)
    zlb, zub = layout.free_bounds()
    lb, ub = np.r_[np.tile(zlb, m), blo], np.r_[np.tile(zub, m), bhi]
    z0 = np.clip(np.r_[_law_stack(A, B, layout), b0], lb, ub)
    keep = inputs.since_start >= float(structure.warmup_s)
    if not keep.any():
        longest = max(b - a for a, b in inputs.trajectory_bounds) * inputs.dt
        raise ConfigError(
            f"the model's warmup_s = {structure.warmup_s} s leaves no training frame "
            f"(the longest trajectory lasts {longest:.1f} s)"
        )
    log_label = np.log(np.maximum(inputs.terminal[keep], FLOOR_N))
    n_keep = int(keep.sum())
    sets = np.array([inputs.n_modules - 1])
    n_eval = 0
    # With no free block parameters the law-free part of the exponent never changes.
    terms = structure.exponent_terms(inputs, start_vals, sets=sets) if not free else None
    # The chain's input: the law and every block parameter but those acting on the terminal reading
    # alone.  The Jacobian's column of such a parameter reuses the chain of the point it steps from.
    in_chain = np.r_[np.ones(m * p, dtype=bool), [not structure.sensor_only(b) for b, _ in names]]
    chains: dict[bytes, NDArray] = {}

    def unpack(z):
        th = np.stack([layout.from_free(z[i * p : (i + 1) * p]) for i in range(m)], axis=1)
        vals = {k: dict(v) for k, v in start_vals.items()}
        for (bn, q), v in zip(names, z[m * p :]):
            vals[bn][q] = float(v)
        a, b = layout.split(th)
        return a, b, vals

    def residual(z):
        nonlocal n_eval
        n_eval += 1
        a, b, vals = unpack(z)
        key = z[in_chain].tobytes()
        if key not in chains:
            if len(chains) >= 4:  # the point a Jacobian steps from and the last few steps
                chains.pop(next(iter(chains)))
            chains[key] = structure.terminal_tension(inputs, a, b, vals, terms=terms)
        pred = structure.sensor_reading(inputs, chains[key], vals)[keep]
        return (np.log(np.maximum(pred, FLOOR_N)) - log_label).T.ravel()  # tendon-major rows

    n_par = m * p + len(names)
    sparsity = lil_matrix((m * n_keep, n_par), dtype=int)
    for i in range(m):
        sparsity[i * n_keep : (i + 1) * n_keep, i * p : (i + 1) * p] = 1
    blocks = {b.name: b for b in structure.block_objects}
    for col, (bn, q) in enumerate(names, start=m * p):
        i = blocks[bn].param_tendon(q)  # a tendon's own parameter moves only that tendon's rows
        rows = slice(None) if i is None else slice(i * n_keep, (i + 1) * n_keep)
        sparsity[rows, col] = 1
    sol = least_squares(
        residual,
        z0,
        bounds=(lb, ub),
        method="trf",
        jac_sparsity=sparsity.tocsr(),
        diff_step=DIFF_STEP,
        x_scale="jac",
        max_nfev=max_nfev,
        ftol=REFIT_TOL if tol is None else tol,
        xtol=REFIT_TOL if tol is None else tol,
    )
    sse0 = float(np.sum(residual(z0) ** 2))
    improved = sol.cost <= 0.5 * sse0
    z = sol.x if improved else z0  # never worse than the start
    a, b, vals = unpack(z)
    if structure.mu_law == "affine-cosine":
        b = np.maximum(b, np.abs(a))
    block_values = {bn: {q: vals[bn][q] for bb, q in names if bb == bn} for bn, _ in names}
    fitted = structure.fitted_with(a, b, inputs.geometry, inputs.n_modules, block_values)
    sse = float(np.sum(sol.fun**2)) if improved else sse0
    fitted.calibration_ = {"loss": sse / (m * n_keep), "status": str(sol.message), "n_eval": n_eval, "starts": 1}
    labels = [f"{ab}[{g}]:{i + 1}" for i in range(m) for ab, g in _law_labels(layout)] + [f"{b}:{q}" for b, q in names]
    corr = jacobian_correlation(sol.jac)
    fitted.calibration_["seconds"] = time.perf_counter() - t0
    return Fit(
        model=fitted,
        sse=sse,
        n_obs=m * n_keep,
        labels=labels,
        n_law=m * p,
        x=z,
        lower=lb,
        upper=ub,
        corr=corr,
        n_eval=n_eval,
        seconds=time.perf_counter() - t0,
        status=str(sol.message),
    )


def _law_labels(layout: LawLayout) -> list[tuple[str, int]]:
    g = layout.n_groups
    if layout.mu_law != "affine-cosine":
        return [("mu", k) for k in range(g)]
    return [("mu0", k) for k in range(g)] + [("r", k) for k in range(g)]
