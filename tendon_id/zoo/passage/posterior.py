"""Bayesian posterior of a calibrated passage model's law and blocks, with emcee (DESIGN §7).

Likelihood: the predicted side's residual is Gaussian with one standard deviation ``sigma``
[N or N m], sampled as ``ln sigma``. At 1 kHz the residual of a fitted model is not white: it
is a model error that stays correlated over many frames, and a likelihood that counted every
frame as an independent datum would overstate the data's information by the residual's
integrated autocorrelation time ``tau`` [frames], and shrink the posterior by ``sqrt(tau)``.
The log-likelihood is therefore that of ``n / tau`` effective frames (Sokal 1997, "Monte Carlo
methods in statistical mechanics", the effective sample size ``n / tau``; the same correction
as a likelihood tempered by ``1 / tau``)::

    ln L = -(n / tau) ln sigma - SSE / (2 tau sigma^2)

with ``tau`` measured once, on the calibrated model's residual (emcee's ``integrated_time``).
Prior: uniform on the box the calibration searched (:func:`~tendon_id.zoo.passage.fitting.parameter_box`:
a gain, a capstan exponent and dissipative block parameters of the right sign), and uniform in
``ln sigma`` on :data:`LOG_SIGMA_RANGE`.

The walkers start in a small ball around the calibrated point and move by differential
evolution (:data:`MOVES`); sampling runs until the chain
is longer than 50 autocorrelation times and reaches the target effective sample size
(:func:`tendon_id.mcmc.run_to_convergence`). Each step evaluates the model once per walker, on
every frame (the stick/slip state needs the whole history): minutes on a bench's twenty files.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import emcee
import numpy as np
from numpy.typing import NDArray

from tendon_id.errors import ConfigError
from tendon_id.mcmc import Chains, corner_figure, ess_rhat, run_to_convergence
from tendon_id.zoo.passage.fitting import parameter_box
from tendon_id.zoo.passage.model import PassageCapstan

#: Prior range of ``ln sigma`` [ln N or ln N m].
LOG_SIGMA_RANGE = (-16.0, 6.0)

#: emcee's moves: differential evolution, with its snooker update a fifth of the time (ter Braak
#: 2006, Statistics and Computing 16:239; ter Braak & Vrugt 2008, ibid. 18:435). A torque pair's
#: gain, exponent, pretension and sharing lie on a curved ridge (their correlation is 0.9999 on
#: the bench), along which these moves mixed about 1.5x faster than the default stretch move
#: (autocorrelation times of 40-77 against 74-108 steps on four bench files).
MOVES = ((emcee.moves.DEMove, 0.8), (emcee.moves.DESnookerMove, 0.2))


@dataclass
class PassagePosterior(Chains):
    """Samples and diagnostics of :func:`sample_passage_posterior` (the fields of :class:`~tendon_id.mcmc.Chains`).

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

    def corner(self):
        """Corner plot of the model's parameters (``corner`` package); returns the figure."""
        return corner_figure(self.samples[:, :-1], self.names[:-1])

    def to_json(self) -> dict:
        """The ``posterior.json`` document of ``tendon-id calibrate --posterior``."""
        return {
            "parameters": self.summary(),
            "tau": float(np.max(self.tau)),
            "residual_tau_frames": self.residual_tau,
            "seconds": self.seconds,
            "acceptance": self.acceptance,
            "walkers": int(self.chain.shape[1]),
            "steps_kept": int(self.chain.shape[0]),
            "min_ess": float(np.min(self.ess)),
            "max_rhat": float(np.max(self.rhat)),
            "prior_box": {n: [float(a), float(b)] for n, a, b in zip(self.names, self.lower, self.upper)},
        }


def sample_passage_posterior(
    model,
    data,
    *,
    n_walkers: int | None = None,
    target_ess: float = 400.0,
    max_steps: int = 5000,
    chunk: int = 200,
    seed: int = 0,
    progress: bool | None = None,
) -> PassagePosterior:
    """Sample the posterior of a calibrated :class:`~tendon_id.zoo.passage.PassageCapstan`.

    Parameters
    ----------
    model : PassageCapstan
        A fitted model; its calibrated point starts the walkers.
    data : PassageRecording, sequence of them, or PassageInputs
        The calibration data.
    n_walkers : int, optional
        emcee walkers (default and minimum: twice the number of parameters, plus 2).
    target_ess : float
        Effective sample size to reach for every parameter.
    max_steps : int
        Give up after this many steps (the result then says so through its ESS and R-hat).
    chunk : int
        Steps between convergence checks.
    seed : int
        Seeds the walkers' start and the sampler: the same seed gives the same chain.
    progress : bool, optional
        Progress bar (default: on a terminal).
    """
    if not isinstance(model, PassageCapstan):
        raise ConfigError("this posterior is defined for passage-capstan models")
    inputs = model.inputs(data)  # raises NotFittedError on an unfitted model
    labels, lo, hi = parameter_box(model, inputs)
    keep = inputs.since_start >= float(model.warmup_s)
    target = model.target(inputs)[keep]
    n_obs = int(keep.sum())
    x_fit = np.array([model.theta_[k] for k in labels])
    resid = model.reading(inputs, model.theta_)[keep] - target
    residual_tau = float(max(emcee.autocorr.integrated_time(resid, c=5, tol=0)[0], 1.0))
    n_eff = n_obs / residual_tau
    names = [*labels, "log_sigma"]
    ndim = len(names)
    n_walkers = max(int(n_walkers or 0), 2 * ndim + 2)
    n_walkers += n_walkers % 2
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

    rng = np.random.default_rng(seed)
    sigma0 = np.sqrt(float(resid @ resid) / n_obs)
    centre = np.r_[x_fit, np.log(max(sigma0, 1e-300))]
    span = upper - lower
    inner = 1e-6 * span
    start = np.clip(centre + 1e-4 * span * rng.standard_normal((n_walkers, ndim)), lower + inner, upper - inner)
    sampler = emcee.EnsembleSampler(n_walkers, ndim, log_prob, moves=[(move(), weight) for move, weight in MOVES])
    sampler.random_state = np.random.RandomState(seed).get_state()  # the same seed gives the same chain
    t0 = time.perf_counter()
    chain, tau = run_to_convergence(
        sampler, start, target_ess=target_ess, max_steps=max_steps, chunk=chunk, progress=progress
    )
    ess, rhat = ess_rhat(names, chain)
    return PassagePosterior(
        names=names,
        chain=chain,
        tau=tau,
        residual_tau=residual_tau,
        ess=ess,
        rhat=rhat,
        acceptance=float(np.mean(sampler.acceptance_fraction)),
        seconds=time.perf_counter() - t0,
        map_theta=centre,
        lower=lower,
        upper=upper,
    )


__all__ = ["LOG_SIGMA_RANGE", "PassagePosterior", "sample_passage_posterior"]
