"""Fitting a passage model: the law and the blocks' parameters in one bounded least-squares fit (DESIGN §7).

The loss is the sum of squared errors of the predicted side over the frames after each log's
warm-up. It is a least-squares problem, so it is solved by scipy's trust-region reflective
method (Branch, Coleman & Li 1999) with a finite-difference Jacobian, as the snake's
diagnosis refits are (:mod:`tendon_id.diagnosis.refit`): on the bench data it needs 10-40
Jacobians, where nlopt's COBYLA ran out of 600 evaluations per start without converging.

The starts come from a linear regression of the *input* on the output and the direction of
motion (the input carries the friction's swing at every reversal, an error in the regressor
that would bias a regression the other way towards zero gain), with the capstan exponent spread
over its range: the gain and the exponent of a taut pair trade off along a ridge
(:mod:`friction_models.passage`), and the best start is kept.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from tendon_id.errors import ConfigError
from tendon_id.metrics import jacobian_correlation
from tendon_id.zoo.passage.blocks import scale_band


@dataclass
class PassageFit:
    """The result of :func:`calibrate_passage`.

    Attributes
    ----------
    theta : dict
        Fitted parameters ``{label: value}`` (the law's, then ``block:param``).
    labels : list of str
    lower, upper : ndarray
        The bounds searched.
    rmse : float
        Training RMSE of the predicted side [N or N m].
    n_obs : int
        Frames in the loss.
    status : str
        The solver's stop reason for the best start.
    n_eval : int
        Model evaluations over all starts.
    seconds : float
    starts : list of float
        The cost reached from each start.
    corr : ndarray, shape (P, P), optional
        Correlation of the parameters from the Jacobian at the solution (Gauss-Newton
        covariance); near +-1 where the data cannot tell two apart.
    """

    theta: dict
    labels: list
    lower: NDArray
    upper: NDArray
    rmse: float
    n_obs: int
    status: str
    n_eval: int
    seconds: float
    starts: list = field(default_factory=list)
    corr: NDArray | None = None

    def summary(self) -> dict:
        return {
            "rmse": self.rmse,
            "n_obs": self.n_obs,
            "status": self.status,
            "n_eval": self.n_eval,
            "seconds": self.seconds,
            "bounds": {k: [float(a), float(b)] for k, a, b in zip(self.labels, self.lower, self.upper)},
        }


def data_scales(inputs) -> dict[str, float]:
    """Typical magnitudes of the data, from which bounds and probes are set (in SI)."""
    travel = inputs.travel()
    angle = inputs.position_out if inputs.position_out is not None else travel
    return {
        "signal": float(np.max(np.abs(inputs.output))) or 1.0,
        "input": float(np.max(np.abs(inputs.input))) or 1.0,
        "travel": float(np.ptp(travel)) or 1.0,
        "angle": float(np.max(np.abs(angle))) or 1.0,
        "speed": float(np.quantile(np.abs(inputs.speed()), 0.95)) or 1.0,
    }


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
    """Law parameters at capstan exponent ``phi``, from a regression of the input on the output and the direction."""
    u, y = inputs.input, inputs.output
    d = inputs.direction(scale_band(inputs))
    if inputs.quantity == "tension":
        ratio = np.log(np.maximum(y, 1e-12)) - np.log(np.maximum(u, 1e-12))
        X = np.column_stack([np.ones_like(u), d])
        (lnk, slope), *_ = np.linalg.lstsq(X, ratio, rcond=None)
        return {"gain": float(np.exp(lnk)), "phi": max(float(-slope), 0.0), "offset": 0.0}
    X = np.column_stack([y, d, np.ones_like(y)])
    (alpha, beta, gamma), *_ = np.linalg.lstsq(X, u, rcond=None)
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


def calibrate_passage(model, inputs, start: dict | None = None) -> PassageFit:
    """Fit ``model``'s law and block parameters on ``inputs`` (see the module docstring).

    Parameters
    ----------
    model : PassageCapstan
    inputs : PassageInputs
    start : dict, optional
        A single start ``{label: value}`` (e.g. a base model's fit; missing labels start
        neutral); by default ``model.n_starts`` starts from the regression.

    Raises
    ------
    ConfigError
        When the warm-up leaves no frame to fit on.
    """
    t0 = time.perf_counter()
    keep = inputs.since_start >= float(model.warmup_s)
    if not keep.any():
        raise ConfigError(f"warmup_s = {model.warmup_s} s leaves no frame to fit on; lower it")
    target = (inputs.output if model.direction == "forward" else inputs.input)[keep]
    labels, lo, hi = parameter_box(model, inputs)
    n_eval = 0

    def residual(x):
        nonlocal n_eval
        n_eval += 1
        return model.reading(inputs, dict(zip(labels, x.tolist())))[keep] - target

    neutral = {f"{b.effect}:{p}": v for b in model.block_objects for p, v in b.neutral().items()}
    if start is not None:
        starts = [{**neutral, **{k: v for k, v in start.items() if k in labels}}]
    else:
        phis = np.linspace(0.1, 1.2, max(int(model.n_starts), 1)) * min(1.0, hi[labels.index("phi")] / 3.0)
        starts = [{**regression_start(inputs, float(p)), **neutral} for p in phis]
    # A parameter that starts on its bound is moved 1 % of its range inside: the reflective
    # trust region scales steps by the distance to the bound and could not leave it.
    inset = 0.01 * (hi - lo)
    best, costs = None, []
    for s in starts:
        x0 = np.clip([s.get(k, 0.5 * (a + b)) for k, a, b in zip(labels, lo, hi)], lo + inset, hi - inset)
        sol = least_squares(
            residual, x0, bounds=(lo, hi), method="trf", x_scale="jac", diff_step=1e-4, max_nfev=int(model.maxeval)
        )
        costs.append(float(sol.cost))
        if best is None or sol.cost < best.cost:
            best = sol
    theta = dict(zip(labels, best.x.tolist()))
    rmse = float(np.sqrt(2.0 * best.cost / keep.sum()))
    return PassageFit(
        theta,
        labels,
        lo,
        hi,
        rmse,
        int(keep.sum()),
        str(best.message),
        n_eval,
        time.perf_counter() - t0,
        costs,
        jacobian_correlation(best.jac),
    )
