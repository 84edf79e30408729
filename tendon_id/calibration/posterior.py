"""The posterior of a calibrated model's law, sampled with emcee: written once for every family.

A family supplies the posterior's :class:`Likelihood` (:meth:`tendon_id.family.Family.likelihood`):
one or more independent :class:`Factor` s, each a block of parameters with its log-probability,
its prior box and the calibrated point the walkers start from (the snake chain's law factorises
over its three tendons; a bench passage has one factor). This module places the walkers, runs one
sampler per factor until it has converged, joins the chains and computes the diagnostics:

* **Walkers** start in a small ball around the calibrated point: ``1e-4`` of each coordinate's
  prior range (of ``1`` for a noise's log, whose prior range is arbitrary), clipped ``1e-6`` of
  it inside the box.
* **Moves**: differential evolution (DE-MC, ter Braak 2006, Statistics and Computing 16:239),
  with its snooker update a fifth of the time (ter Braak & Vrugt 2008, ibid. 18:435). On the
  snake's law their autocorrelation time is about 2.5 times shorter than the default stretch
  move's (snake12-paper pool); on a torque pair's curved ridge of gain, exponent, pretension and
  sharing (correlation 0.9999 on the bench) they mixed about 1.5 times faster (autocorrelation
  times of 40-77 against 74-108 steps on four bench files).
* **Convergence** follows the integrated autocorrelation time (Goodman & Weare 2010; emcee's
  ``get_autocorr_time``): sampling continues until the chain is longer than 50 ``tau`` and
  reaches the target effective sample size (:func:`~tendon_id.calibration.mcmc.run_to_convergence`);
  ESS and R-hat of the result come from ArviZ.
* **Noise**: every likelihood samples each noise's natural log, uniform on
  :data:`LOG_SIGMA_RANGE` (a noise of 1e-7 to 400 in its unit, N or N m).

The same seed gives the same chain: factor ``i``'s sampler is seeded with ``[seed, i]``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import emcee
import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration.mcmc import Chains, corner_figure, ess_rhat, run_to_convergence
from tendon_id.checks import check_count, check_positive
from tendon_id.errors import ConfigError

__all__ = ["LOG_SIGMA_RANGE", "Factor", "Likelihood", "Posterior", "de_moves", "sample_posterior"]

#: Prior range of every noise's natural log [ln N or ln N m].
LOG_SIGMA_RANGE = (-16.0, 6.0)


def de_moves() -> list:
    """emcee's differential-evolution moves (80 %) with snooker updates (20 %), a fresh set for one sampler."""
    return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]


@dataclass(frozen=True)
class Factor:
    """One independent block of a posterior, sampled by a sampler of its own.

    Attributes
    ----------
    log_prob : callable
        The log-posterior of a row of coordinates (``vectorize``: of rows, shape (W, d) -> (W,));
        ``-inf`` outside the prior.
    centre : ndarray, shape (d,)
        The calibrated point, where the walkers start.
    lower, upper : ndarray, shape (d,)
        The prior's box in the sampled coordinates.
    n_noise : int
        How many of the last coordinates are noises' logs (they join the other factors' noises
        at the end of the chain).
    vectorize : bool
        ``log_prob`` takes all walkers at once.
    desc : str
        Its progress bar's label.
    """

    log_prob: Callable
    centre: NDArray
    lower: NDArray
    upper: NDArray
    n_noise: int = 1
    vectorize: bool = False
    desc: str = "emcee"

    @property
    def dim(self) -> int:
        return int(np.size(self.centre))

    @property
    def span(self) -> NDArray:
        """The scale of the walkers' starting ball per coordinate: its prior range, 1 for a noise's log."""
        span = np.asarray(self.upper - self.lower, dtype=float).copy()
        span[self.dim - self.n_noise :] = 1.0
        return span


@dataclass
class Likelihood:
    """A family's posterior of one fitted model: its factors and what to make of their joined chain.

    Attributes
    ----------
    factors : list of Factor
    names : list of str
        The reported parameters, in the joined chain's order: every factor's law coordinates,
        then every factor's noises.
    map_theta : ndarray
        The calibrated point in the reported parameters.
    n_walkers : int or None
        Walkers of each sampler by default (None: ``2 d + 2`` for a factor of ``d`` coordinates).
    target_ess, max_steps, chunk :
        The family's defaults of :func:`sample_posterior`'s settings.
    finish : callable, optional
        ``finish(chain, rng, seed) -> (chain, fields)``: the joined chain of the sampled
        coordinates (steps, walkers, params) into the reported parameters, and further fields of
        the result (default: as it is). ``rng`` is the generator that placed the walkers.
    result : type
        The :class:`Posterior` subclass to return.
    extra : dict
        Further fields of that result.
    """

    factors: list
    names: list
    map_theta: NDArray
    n_walkers: int | None = None
    target_ess: float = 400.0
    max_steps: int = 5000
    chunk: int = 200
    finish: Callable | None = None
    result: type = None
    extra: dict = field(default_factory=dict)


@dataclass
class Posterior(Chains):
    """Samples and diagnostics of :func:`sample_posterior` (the fields of :class:`~tendon_id.calibration.mcmc.Chains`).

    ``names`` are the family's (:class:`Likelihood`): the law's parameters, then each noise's
    natural log ``log_sigma...`` in the passage's or tendon's unit.
    """

    def to_dict(self) -> dict[str, Any]:
        """The ``posterior.json`` document of ``tendon-id calibrate --posterior``."""
        return {
            "parameters": self.statistics(),
            "tau": float(np.max(self.tau)),
            "seconds": self.seconds,
            "acceptance": self.acceptance,
            "walkers": int(self.chain.shape[1]),
            "steps_kept": int(self.chain.shape[0]),
            "min_ess": float(np.min(self.ess)),
            "max_rhat": float(np.max(self.rhat)),
        }

    def corner(self, truths=None):
        """Corner plot of the law's parameters (the noises left out; ``corner`` package); returns the figure."""
        keep = [k for k, n in enumerate(self.names) if not n.startswith("log_sigma")]
        return corner_figure(
            self.samples[:, keep],
            [self.names[k] for k in keep],
            None if truths is None else [truths[k] for k in keep],
        )


def place_walkers(factors: list[Factor], n_walkers: int, rng: np.random.Generator) -> list[NDArray]:
    """Each factor's walkers, shape (n_walkers, d): one draw for all, in the joined chain's order."""
    law = [slice(0, f.dim - f.n_noise) for f in factors]
    noise = [slice(f.dim - f.n_noise, f.dim) for f in factors]

    def joined(get):
        return np.r_[tuple(get(f)[s] for f, s in zip(factors, law)) + tuple(get(f)[s] for f, s in zip(factors, noise))]

    centre, span = joined(lambda f: f.centre), joined(lambda f: f.span)
    lo, hi = joined(lambda f: f.lower) + 1e-6 * span, joined(lambda f: f.upper) - 1e-6 * span
    start = np.clip(centre + 1e-4 * span * rng.standard_normal((n_walkers, centre.size)), lo, hi)
    out, at_law, at_noise = [], 0, sum(s.stop for s in law)
    for f in factors:
        k = f.dim - f.n_noise
        out.append(np.concatenate([start[:, at_law : at_law + k], start[:, at_noise : at_noise + f.n_noise]], axis=1))
        at_law, at_noise = at_law + k, at_noise + f.n_noise
    return out


def sample_posterior(
    model,
    data,
    *,
    n_walkers: int | None = None,
    target_ess: float | None = None,
    max_steps: int | None = None,
    chunk: int | None = None,
    seed: int = 0,
    progress: bool | None = None,
    **options,
) -> Posterior:
    """Sample the posterior of a calibrated model's law (see the module docstring).

    Parameters
    ----------
    model : Estimator
        A fitted model with a law (``tendon-id calibrate``'s models); its calibrated point starts
        the walkers, and its family gives the likelihood.
    data : recording, or sequence of them
        The calibration data.
    n_walkers : int, optional
        Walkers of each factor's sampler (at least twice its dimension; made even). Default:
        the family's.
    target_ess : float, optional
        Effective sample size to reach for every parameter. Default: the family's.
    max_steps : int, optional
        Give up after this many steps (the result then says so through its ESS and R-hat).
    chunk : int, optional
        Steps between convergence checks.
    seed : int
        Seeds the walkers' start and the samplers: the same seed gives the same chain.
    progress : bool, optional
        Progress bars (default: on a terminal).
    **options
        The family's own (the snake chain's ``encoder_bits``).

    Returns
    -------
    Posterior
        The family's subclass of it (:attr:`Likelihood.result`).
    """
    likelihood = model.family.likelihood(model, data, **options)  # raises NotFittedError on an unfitted model
    target_ess = check_positive("target_ess", likelihood.target_ess if target_ess is None else target_ess)
    max_steps = check_count("max_steps", likelihood.max_steps if max_steps is None else max_steps)
    chunk = check_count("chunk", likelihood.chunk if chunk is None else chunk)
    factors = likelihood.factors
    d = max(f.dim for f in factors)
    n_walkers = check_count("n_walkers", likelihood.n_walkers or 2 * d + 2 if n_walkers is None else n_walkers)
    n_walkers = max(n_walkers, 2 * d)
    n_walkers += n_walkers % 2
    rng = np.random.default_rng(seed)
    starts = place_walkers(factors, n_walkers, rng)

    t0 = time.perf_counter()
    parts, taus, acceptance = [], [], []
    for i, (f, start) in enumerate(zip(factors, starts)):
        lp = f.log_prob(start) if f.vectorize else np.array([f.log_prob(z) for z in start])
        if not np.all(np.isfinite(lp)):  # pragma: no cover - the clip keeps every start inside the box
            raise ConfigError("could not place the walkers inside the prior")
        sampler = emcee.EnsembleSampler(n_walkers, f.dim, f.log_prob, moves=de_moves(), vectorize=f.vectorize)
        sampler.random_state = np.random.RandomState([seed, i]).get_state()
        z, tau = run_to_convergence(
            sampler, start, target_ess=target_ess, max_steps=max_steps, chunk=chunk, progress=progress, desc=f.desc
        )
        parts.append(z)
        taus.append(tau)
        acceptance.append(float(np.mean(sampler.acceptance_fraction)))
    steps = min(z.shape[0] for z in parts)  # independent factors: the last draws of each, side by side
    k = [f.dim - f.n_noise for f in factors]
    chain = np.concatenate(
        [z[-steps:, :, :n] for z, n in zip(parts, k)] + [z[-steps:, :, n:] for z, n in zip(parts, k)], axis=2
    )
    tau = np.r_[tuple(t[:n] for t, n in zip(taus, k)) + tuple(t[n:] for t, n in zip(taus, k))]
    extra = dict(likelihood.extra)
    if likelihood.finish is not None:
        chain, more = likelihood.finish(chain, rng, seed)
        extra.update(more)
    ess, rhat = ess_rhat(likelihood.names, chain)
    return (likelihood.result or Posterior)(
        names=list(likelihood.names),
        chain=chain,
        tau=tau,
        ess=ess,
        rhat=rhat,
        acceptance=float(np.mean(acceptance)),
        seconds=time.perf_counter() - t0,
        map_theta=likelihood.map_theta,
        **extra,
    )
