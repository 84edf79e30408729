"""The bench passage's posterior: a calibrated passage model's law, blocks and residual noise.

See :doc:`/guide/calibration`.

The likelihood the generic sampler (:func:`tendon_id.calibration.posterior.sample_posterior`)
runs for a passage model. The predicted side's residual is Gaussian with one standard deviation
``sigma`` [N or N m], sampled as ``ln sigma``. At 1 kHz the residual of a fitted model is not
white: it is a model error that stays correlated over many frames, and a likelihood that counted
every frame as an independent datum would overstate the data's information by the residual's
integrated autocorrelation time ``tau`` [frames], and shrink the posterior by ``sqrt(tau)``. The
log-likelihood is therefore that of ``n / tau`` effective frames (Sokal 1997, "Monte Carlo
methods in statistical mechanics", the effective sample size ``n / tau``; the same correction as
a likelihood tempered by ``1 / tau``)::

    ln L = -(n / tau) ln sigma - SSE / (2 tau sigma^2)

with ``tau`` measured once, on the calibrated model's residual (emcee's ``integrated_time``).
Prior: uniform on the box the calibration searched (:func:`~tendon_id.zoo.passage.fitting.parameter_box`:
a gain, a capstan exponent and dissipative block parameters of the right sign), and uniform in
``ln sigma`` on :data:`~tendon_id.calibration.posterior.LOG_SIGMA_RANGE`.

One factor holds every parameter; each step evaluates the model once per walker, on every frame
(the stick/slip state needs the whole history): minutes on a bench's twenty files.
"""

from __future__ import annotations

from dataclasses import dataclass

import emcee
import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration.posterior import LOG_SIGMA_RANGE, Factor, Likelihood, Posterior
from tendon_id.zoo.passage.fitting import parameter_box

__all__ = ["PassagePosterior", "passage_likelihood"]


@dataclass
class PassagePosterior(Posterior):
    """The bench passage's posterior (the fields of :class:`~tendon_id.calibration.posterior.Posterior`).

    ``names`` are the model's parameter labels, then ``log_sigma`` (natural log of the residual's
    standard deviation in the passage's unit); ``map_theta`` ends with its calibrated value.

    Attributes
    ----------
    residual_tau : float
        Integrated autocorrelation time of the calibrated model's residual [frames]: the
        likelihood counts ``n / residual_tau`` effective frames.
    lower, upper : ndarray
        The prior's box.
    """

    residual_tau: float = 1.0
    lower: NDArray | None = None
    upper: NDArray | None = None

    def to_dict(self) -> dict:
        """The ``posterior.json`` document, with the residual's autocorrelation time and the prior's box."""
        return {
            **super().to_dict(),
            "residual_tau_frames": self.residual_tau,
            "prior_box": {n: [float(a), float(b)] for n, a, b in zip(self.names, self.lower, self.upper)},
        }


def passage_likelihood(model, data) -> Likelihood:
    """The posterior of a calibrated :class:`~tendon_id.zoo.passage.PassageCapstan` (see the module docstring).

    Parameters
    ----------
    model : PassageCapstan
        A fitted model; its calibrated point starts the walkers.
    data : PassageRecording, sequence of them, or PassageInputs
        The calibration data.
    """
    inputs = model.inputs(data)  # raises NotFittedError on an unfitted model
    labels, lo, hi = parameter_box(model, inputs)
    keep = inputs.since_start >= float(model.warmup_s)
    target = model.target(inputs)[keep]
    n_obs = int(keep.sum())
    x_fit = np.array([model.theta_[k] for k in labels])
    resid = model.reading(inputs, model.theta_)[keep] - target
    residual_tau = float(max(emcee.autocorr.integrated_time(resid, c=5, tol=0)[0], 1.0))
    n_eff = n_obs / residual_tau
    lower = np.r_[lo, LOG_SIGMA_RANGE[0]]
    upper = np.r_[hi, LOG_SIGMA_RANGE[1]]

    def log_prob(z: NDArray) -> float:
        if np.any(z < lower) or np.any(z > upper):
            return -np.inf
        e = model.reading(inputs, dict(zip(labels, z[:-1].tolist())))[keep] - target
        sse = float(e @ e)
        if not np.isfinite(sse):
            return -np.inf
        return -n_eff * z[-1] - 0.5 * sse * np.exp(-2.0 * z[-1]) / residual_tau

    sigma0 = np.sqrt(float(resid @ resid) / n_obs)
    centre = np.r_[x_fit, np.log(max(sigma0, 1e-300))]
    return Likelihood(
        factors=[Factor(log_prob=log_prob, centre=centre, lower=lower, upper=upper)],
        names=[*labels, "log_sigma"],
        map_theta=centre,
        target_ess=400.0,
        max_steps=5000,
        chunk=200,
        result=PassagePosterior,
        extra={"residual_tau": residual_tau, "lower": lower, "upper": upper},
    )
