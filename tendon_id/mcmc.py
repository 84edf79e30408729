"""Convergence diagnostics of MCMC chains with ArviZ: bulk effective sample size and split R-hat.

Both follow Vehtari, Gelman, Simpson, Carpenter & Bürkner (2021), "Rank-normalization,
folding, and localization: an improved R-hat for assessing convergence of MCMC", Bayesian
Analysis 16(2), as implemented by ``arviz.ess`` (``method="bulk"``) and ``arviz.rhat``
(``method="rank"``).  An ensemble sampler's walkers are treated as chains.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

with warnings.catch_warnings():
    # ArviZ 0.2x announces its coming 1.0 refactor with a FutureWarning at import, once a day per
    # machine: it would land in the output of whichever command, test or docs example first imports
    # us that day, and there is nothing our users can do about it.  Only that message is silenced.
    warnings.filterwarnings("ignore", message=r"\s*ArviZ is undergoing a major refactor", category=FutureWarning)
    import arviz as az


def inference_data(names: Sequence[str], chain: NDArray) -> az.InferenceData:
    """An ``arviz.InferenceData`` of ``chain`` (steps, walkers, params), one chain per walker."""
    return az.from_dict(posterior={n: chain[:, :, k].T for k, n in enumerate(names)})


def ess_rhat(names: Sequence[str], chain: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Bulk effective sample size and rank-normalised split R-hat per parameter, each shape (params,).

    Parameters
    ----------
    names : sequence of str
        Parameter names, one per last-axis entry of ``chain``.
    chain : ndarray, shape (steps, walkers, params)
    """
    idata = inference_data(names, chain)
    ess = np.array([float(az.ess(idata, var_names=[n])[n].values) for n in names])
    rhat = np.array([float(az.rhat(idata, var_names=[n])[n].values) for n in names])
    return ess, rhat
