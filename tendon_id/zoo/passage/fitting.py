"""Fitting a passage model: the law and the blocks' parameters in one bounded least-squares fit.

See :doc:`/guide/calibration`.

The loss is the sum of squared errors of the predicted side over the frames after each log's
warm-up, minimised under the parameters' bounds with nlopt, as the snake's law is
(:func:`tendon_id.calibration.optimize.minimize`): SLSQP (Kraft 1988) on the gradient ``2 J^T r``, with the
residual's Jacobian ``J`` from forward differences. The model is piecewise smooth in its
parameters (the play operator switches edge at reversals, not as the parameters move), so the
difference quotients are those of the smooth piece. Derivative-free COBYLA ran out of 600
evaluations per start without converging on the bench data; SLSQP reached the same optimum as a
trust-region least-squares solver (scipy's ``trf``, Branch, Coleman & Li 1999) to 1e-7 relative in
RMSE on ``Tool_4_Maryland_L_2``, in 0.7-1.0x its time.

The starts come from a linear regression of the *input* on the output and the direction of
motion (the input carries the friction's swing at every reversal, an error in the regressor
that would bias a regression the other way towards zero gain), with the capstan exponent spread
over its range: the gain and the exponent of a taut pair trade off along a ridge
(:mod:`friction_models.passage`), and the best start is kept.

An hour's log at 1 kHz is 3.6·10^6 frames, and a Jacobian of them per gradient would be
several times the recording. Nothing here holds one: the model is read in windows of frames
(:meth:`~tendon_id.zoo.passage.model.PassageCapstan.reading_windows`, its play state carried
between them), the ``P + 1`` readings of a forward-difference Jacobian go through the windows
together, and only the sums ``r^T r``, ``J^T r`` and ``J^T J`` are kept (``P`` numbers and a
``P x P`` matrix). The starts' regression sums its normal equations over the same windows.
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration.optimize import minimize
from tendon_id.errors import ConfigError
from tendon_id.family.fit import Fit
from tendon_id.metrics import gram_correlation
from tendon_id.zoo.passage.blocks import scale_band
from tendon_id.zoo.passage.inputs import WINDOW_FRAMES

#: Relative forward-difference step of the Jacobian (the model is in float64; the play
#: operator's edges are smooth in the parameters between reversals).
FD_STEP = 1e-6
#: nlopt's stopping rules: relative change of the parameters, and of the sum of squares.
XTOL_REL, FTOL_REL = 1e-6, 1e-10


def calibration_record(fit: Fit) -> dict:
    """A passage model's ``calibration_``: the fit's loss, stop, bounds and parameter correlations."""
    return {
        "rmse": fit.rmse,
        "n_obs": fit.n_obs,
        "status": fit.status,
        "n_eval": fit.n_eval,
        "seconds": fit.seconds,
        "bounds": {k: [float(a), float(b)] for k, a, b in zip(fit.labels, fit.lower, fit.upper)},
        # Rows and columns in the order of ``bounds``; None where a parameter does not act.
        "correlation": None
        if fit.corr is None
        else [[float(v) if np.isfinite(v) else None for v in row] for row in fit.corr],
    }


def data_scales(inputs) -> dict[str, float]:
    """Typical magnitudes of the data, from which bounds and probes are set (in SI)."""
    travel = inputs.travel()
    angle = inputs.position_out if inputs.position_out is not None else travel
    return {
        "signal": _max_abs(inputs.output) or 1.0,
        "input": _max_abs(inputs.input) or 1.0,
        "travel": float(np.ptp(travel)) or 1.0,
        "angle": _max_abs(angle) or 1.0,
        "speed": float(np.quantile(inputs.speed_magnitude(), 0.95, overwrite_input=True)) or 1.0,
        "dt": float(inputs.dt),
    }


def _max_abs(x: NDArray) -> float:
    """``max(|x|)`` without the copy ``np.abs`` makes: the same value (NaN if any is)."""
    hi, lo = float(np.max(x)), float(np.min(x))
    return float("nan") if np.isnan(hi) or np.isnan(lo) else max(hi, -lo)


def parameter_box(model, inputs) -> tuple[list[str], NDArray, NDArray]:
    """Labels and bounds of every fitted parameter."""
    s = data_scales(inputs)
    wrap = float(np.max(inputs.wrap)) if inputs.wrap is not None else 1.0
    law = {
        "gain": (0.05, 20.0),
        "phi": (0.0, 3.0 / wrap),
        "pretension": (0.0, 5.0 * s["input"]),
        "sharing": (0.0, 1.0),
        "offset": (-2.0 * s["signal"], 2.0 * s["signal"]),
        "input_offset": (-s["input"], s["input"]),
    }
    labels = model.param_labels(inputs.quantity)
    box = []
    for lab in labels:
        if ":" in lab:
            effect, p = lab.split(":")
            box.append(next(b for b in model.block_objects if b.effect == effect).bounds(s)[p])
        else:
            box.append(law[lab])
    lo, hi = np.array(box, dtype=float).T
    return labels, lo, hi


def regression_start(inputs, phi: float) -> dict[str, float]:
    """Law parameters at capstan exponent ``phi``, from a regression of the input on the output and the direction.

    The least squares are solved from their normal equations, summed over windows of frames.
    """
    d_all = inputs.direction(scale_band(inputs))
    tension = inputs.quantity == "tension"
    k = 2 if tension else 3
    XtX, Xtb = np.zeros((k, k)), np.zeros(k)
    for a in range(0, inputs.n_frames, WINDOW_FRAMES):
        u, y, d = (v[a : a + WINDOW_FRAMES] for v in (inputs.input, inputs.output, d_all))
        if tension:
            X = np.column_stack([np.ones_like(u), d])
            b = np.log(np.maximum(y, 1e-12)) - np.log(np.maximum(u, 1e-12))
        else:
            X, b = np.column_stack([y, d, np.ones_like(y)]), u
        XtX += X.T @ X
        Xtb += X.T @ b
    coef = np.linalg.lstsq(XtX, Xtb, rcond=None)[0]
    if tension:
        lnk, slope = coef
        return {"gain": float(np.exp(lnk)), "phi": max(float(-slope), 0.0), "offset": 0.0}
    alpha, beta, gamma = coef
    a = 1.0 / alpha if alpha > 0 else 1.0  # y = a u - b d + c
    gain = a / np.cosh(phi)
    return {
        "gain": float(gain),
        "phi": phi,
        "pretension": max(float(beta * a), 0.0) / (2.0 * gain * max(np.sinh(phi), 1e-6)),
        "sharing": 0.1,
        "offset": float(-gamma * a),
        "input_offset": 0.0,
    }


def calibrate_passage(model, inputs, start: dict | None = None) -> Fit:
    """Fit ``model``'s law and block parameters on ``inputs`` (see the module docstring).

    Parameters
    ----------
    model : PassageCapstan
    inputs : PassageInputs
    start : dict, optional
        A single start ``{label: value}`` (e.g. a base model's fit; missing labels start
        neutral); by default ``model.n_starts`` starts from the regression.

    Returns
    -------
    Fit
        Without a model (``Fit.model`` is None: the caller stores the parameters); ``sse`` is
        the sum of squared errors of the predicted side [Q^2].

    Raises
    ------
    ConfigError
        When the warm-up leaves no frame to fit on.
    """
    t0 = time.perf_counter()
    keep = inputs.since_start >= float(model.warmup_s)
    if not keep.any():
        raise ConfigError(f"warmup_s = {model.warmup_s} s leaves no frame to fit on; lower it")
    target = inputs.output if model.direction == "forward" else inputs.input
    labels, lo, hi = parameter_box(model, inputs)
    n_eval = 0

    def residuals(x):
        """The residual after the warm-up [Q], window by window."""
        nonlocal n_eval
        n_eval += 1
        for a, b, y in model.reading_windows(inputs, dict(zip(labels, x.tolist()))):
            yield (y - target[a:b])[keep[a:b]]

    def sse(x):
        return sum(float(r @ r) for r in residuals(x))

    scales = data_scales(inputs)
    neutral = {f"{b.effect}:{p}": v for b in model.block_objects for p, v in b.initial(scales).items()}
    if start is not None:
        starts = [{**neutral, **{k: v for k, v in start.items() if k in labels}}]
    else:
        phis = np.linspace(0.1, 1.2, max(int(model.n_starts), 1)) * min(1.0, hi[labels.index("phi")] / 3.0)
        starts = [{**regression_start(inputs, float(p)), **neutral} for p in phis]
    # A parameter that starts on its bound is moved 1 % of its range inside, so that the first
    # difference quotients see both sides of the start.
    inset = 0.01 * (hi - lo)
    best, costs = None, []
    for s in starts:
        x0 = np.clip([s.get(k, 0.5 * (a + b)) for k, a, b in zip(labels, lo, hi)], lo + inset, hi - inset)
        # nlopt's SLSQP does not scale the parameters: it works on x d, with d the norms of the
        # Jacobian's columns at the start (Moré 1978's scaling, scipy's x_scale="jac").
        d = np.maximum(np.sqrt(np.diag(jacobian_sums(residuals, x0, lo, hi)[2])), 1e-12)

        def value_and_gradient(u, d=d):
            f, Jtr, _ = jacobian_sums(residuals, u / d, lo, hi)
            return f, 2.0 * Jtr / d

        out = minimize(
            lambda u, d=d: sse(u / d),
            x0 * d,
            lb=lo * d,
            ub=hi * d,
            fun_grad=value_and_gradient,
            xtol_rel=XTOL_REL,
            ftol_rel=FTOL_REL,
            maxeval=int(model.maxeval),
        )
        out.x = out.x / d
        costs.append(0.5 * out.f)
        if best is None or out.f < best.f:
            best = out
    n_fit = n_eval  # the fit's evaluations, before the Jacobian that gives the correlations
    return Fit(
        model=None,
        sse=float(best.f),
        n_obs=int(keep.sum()),
        labels=labels,
        n_law=len(labels) - sum(len(b.param_names) for b in model.block_objects),
        x=best.x,
        lower=lo,
        upper=hi,
        corr=gram_correlation(jacobian_sums(residuals, best.x, lo, hi)[2]),
        n_eval=n_fit,
        seconds=time.perf_counter() - t0,
        status=best.status,
        starts=costs,
    )


def jacobian_sums(residuals, x: NDArray, lo: NDArray, hi: NDArray) -> tuple[float, NDArray, NDArray]:
    """``r^T r``, ``J^T r`` and ``J^T J`` at ``x``, of the forward-difference Jacobian ``J`` of ``residuals``.

    ``residuals(x)`` yields the residual window by window; the ``P + 1`` evaluations go through
    the windows together, so no array of the log's length is held. Steps stay inside
    ``[lo, hi]``: the step of parameter ``k`` is ``FD_STEP * max(|x_k|, 1e-3 (hi_k - lo_k))``,
    taken backwards where a forward step would leave the box.
    """
    h = FD_STEP * np.maximum(np.abs(x), 1e-3 * (hi - lo))
    h = np.where(x + h > hi, -h, h)
    steps = [x, *(x + np.diag(h))]
    rr, Jtr, JtJ = 0.0, np.zeros(x.size), np.zeros((x.size, x.size))
    for r0, *shifted in zip(*(residuals(p) for p in steps)):
        J = np.column_stack([(r - r0) / hk for r, hk in zip(shifted, h)]) if shifted else np.empty((r0.size, 0))
        rr += float(r0 @ r0)
        Jtr += J.T @ r0
        JtJ += J.T @ J
    return rr, Jtr, JtJ


def confounded_groups(labels: list[str], corr: NDArray | None, threshold: float = 0.99) -> list[list[str]]:
    """Groups of parameters linked by ``|correlation| > threshold``: combinations the data pins, not each one.

    The connected components of the graph whose edges are the strongly correlated pairs; only
    groups of two or more are returned.
    """
    if corr is None:
        return []
    strong = np.abs(np.nan_to_num(np.asarray(corr, dtype=float))) > threshold
    group = list(range(len(labels)))

    def root(i):
        while group[i] != i:
            i = group[i]
        return i

    for i, j in zip(*np.nonzero(np.triu(strong, 1))):
        group[root(int(i))] = root(int(j))
    out: dict[int, list[str]] = {}
    for i, lab in enumerate(labels):
        out.setdefault(root(i), []).append(lab)
    return [g for g in out.values() if len(g) > 1]
