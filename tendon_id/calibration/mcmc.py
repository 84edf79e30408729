"""Convergence diagnostics of MCMC chains with ArviZ: bulk effective sample size and split R-hat.

Both follow Vehtari, Gelman, Simpson, Carpenter & Bürkner (2021), "Rank-normalization,
folding, and localization: an improved R-hat for assessing convergence of MCMC", Bayesian
Analysis 16(2), as implemented by ``arviz.ess`` (``method="bulk"``) and ``arviz.rhat``
(``method="rank"``).  An ensemble sampler's walkers are treated as chains.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

with warnings.catch_warnings():
    # ArviZ 0.2x announces its coming 1.0 refactor with a FutureWarning at import, once a day per
    # machine: it would land in the output of whichever command, test or docs example first imports
    # us that day, and there is nothing our users can do about it.  Only that message is silenced.
    warnings.filterwarnings("ignore", message=r"\s*ArviZ is undergoing a major refactor", category=FutureWarning)
    import arviz as az

from tendon_id.progress import progress_bar


def inference_data(names: Sequence[str], chain: NDArray) -> az.InferenceData:
    """An ``arviz.InferenceData`` of ``chain`` (steps, walkers, params), one chain per walker."""
    # Contiguous copies: xarray handles a strided view about 20 times more slowly.
    return az.from_dict(posterior={n: np.ascontiguousarray(chain[:, :, k].T) for k, n in enumerate(names)})


def ess_rhat(names: Sequence[str], chain: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Bulk effective sample size and rank-normalised split R-hat per parameter, each shape (params,).

    Parameters
    ----------
    names : sequence of str
        Parameter names, one per last-axis entry of ``chain``.
    chain : ndarray, shape (steps, walkers, params)
    """
    idata = inference_data(names, chain)
    ess_all, rhat_all = az.ess(idata), az.rhat(idata)  # one call each for every parameter
    ess = np.array([float(ess_all[n].values) for n in names])
    rhat = np.array([float(rhat_all[n].values) for n in names])
    return ess, rhat


@dataclass
class Chains:
    """An emcee chain and its diagnostics: what every posterior of tendon-id returns.

    Attributes
    ----------
    names : list of str
        Parameter names, one per last-axis entry of ``chain``.
    chain : ndarray, shape (steps, walkers, params)
        Chain after burn-in.
    tau : ndarray, shape (params,)
        Integrated autocorrelation time of the sampled coordinates [steps].
    ess, rhat : ndarray, shape (params,)
        ArviZ bulk effective sample size and split R-hat (walkers as chains).
    acceptance : float
        Mean acceptance fraction.
    seconds : float
        Wall time of the sampling [s].
    map_theta : ndarray
        The calibrated point the walkers started from.
    """

    names: list
    chain: NDArray
    tau: NDArray
    ess: NDArray
    rhat: NDArray
    acceptance: float
    seconds: float
    map_theta: NDArray

    @property
    def samples(self) -> NDArray:
        """Flattened draws, shape (draws, params)."""
        return self.chain.reshape(-1, self.chain.shape[-1])

    def statistics(self) -> dict:
        """``{name: {"mean", "sd", "q2.5", "q97.5", "ess", "rhat"}}``.

        The ``parameters`` of ``posterior.json`` (:doc:`/cli`).
        """
        return chain_statistics(self.names, self.chain)

    def summary(self) -> str:
        """One line per parameter: mean, sd, 95 % interval, ESS and R-hat, for a terminal."""
        stats = self.statistics()
        return "\n".join(
            f"{n:16s} {s['mean']:11.4g} ± {s['sd']:9.3g}  [{s['q2.5']:.4g}, {s['q97.5']:.4g}]  "
            f"ESS {s['ess']:7.0f}  R-hat {s['rhat']:.3f}"
            for n, s in stats.items()
        )

    def to_arviz(self) -> az.InferenceData:
        """An ``arviz.InferenceData`` with one chain per walker."""
        return inference_data(self.names, self.chain)


def chain_statistics(names: Sequence[str], chain: NDArray) -> dict:
    """``{name: {"mean", "sd", "q2.5", "q97.5", "ess", "rhat"}}`` of ``chain`` (steps, walkers, params)."""
    s = chain.reshape(-1, chain.shape[-1])
    q = np.percentile(s, [2.5, 97.5], axis=0)
    ess, rhat = ess_rhat(names, chain)
    return {
        n: {
            "mean": float(s[:, k].mean()),
            "sd": float(s[:, k].std(ddof=1)),
            "q2.5": float(q[0, k]),
            "q97.5": float(q[1, k]),
            "ess": float(ess[k]),
            "rhat": float(rhat[k]),
        }
        for k, n in enumerate(names)
    }


def corner_figure(samples: NDArray, labels: Sequence[str], truths: Sequence[float] | None = None):
    """Corner plot of ``samples`` (draws, params) with 2.5/50/97.5 % quantiles (``corner`` package)."""
    # corner is the optional ``posterior`` extra, and the Agg backend is process-wide: both on use.
    import corner
    import matplotlib

    matplotlib.use("Agg")
    return corner.corner(samples, labels=list(labels), truths=truths, quantiles=[0.025, 0.5, 0.975])


def run_to_convergence(
    sampler, start: NDArray, *, target_ess: float, max_steps: int, chunk: int, progress: bool | None, desc="emcee"
) -> tuple[NDArray, NDArray]:
    """Run an ``emcee.EnsembleSampler`` from ``start`` until its chain is long and mixed enough.

    Sampling goes on in chunks of ``chunk`` steps until the chain is longer than 50 times the
    largest integrated autocorrelation time ``tau`` (Goodman & Weare 2010; emcee's
    ``get_autocorr_time``) and ``walkers (steps - burn) / tau`` reaches ``target_ess``, or
    ``max_steps`` is spent. The burn-in is ``2 tau``, at most half the chain.

    Returns
    -------
    chain : ndarray, shape (steps - burn, walkers, params)
    tau : ndarray, shape (params,)
        [steps].
    """
    steps, state = 0, start
    n_walkers = start.shape[0]
    tau = np.full(start.shape[1], np.inf)
    for _ in progress_bar(range(max(max_steps // chunk, 1)), desc=desc, enable=progress):
        state = sampler.run_mcmc(state, chunk, progress=False)
        steps += chunk
        tau = sampler.get_autocorr_time(tol=0)
        longest = float(np.max(tau))
        if not np.isfinite(longest):  # a chain too short (or stuck) to estimate tau: not converged
            continue
        burn = int(np.ceil(2 * longest))
        if steps > 50 * longest and n_walkers * (steps - burn) / longest >= target_ess:
            break
    longest = float(np.max(tau))
    burn = min(int(np.ceil(2 * longest)), steps // 2) if np.isfinite(longest) else steps // 2
    return sampler.get_chain(discard=burn), np.asarray(tau, dtype=float)
