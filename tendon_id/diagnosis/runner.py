"""Refit structures on every split and score them on the held-out frames, serially or as joblib jobs."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tendon_id.diagnosis.stats import bootstrap_ci, frame_mean_squares, improvement_ci
from tendon_id.family.fit import Fit
from tendon_id.family.inputs import forget
from tendon_id.progress import progress_bar


@dataclass
class Score:
    """A structure refitted on each split.

    Attributes
    ----------
    fits : list of Fit
        One per split.
    residual : ndarray, shape (T, C)
        Measured minus predicted reading on the held-out frames of every split [the family's
        unit]; NaN in the model's warm-up.
    """

    fits: list
    residual: NDArray


def refit_and_score(family, structure, split, start, max_nfev: int, tol=None) -> tuple[Fit, NDArray]:
    """One job: refit ``structure`` on ``split``'s training inputs from ``start``, its residual on the held-out ones.

    A training set of parts is stacked for this job only (:meth:`~tendon_id.diagnosis.splits.Split.training`),
    and both sides forget their derived arrays afterwards: a diagnosis holds its splits for its
    whole run, and their derived arrays would be a few bytes per frame for each of them.
    """
    train = split.training()
    try:
        # A family written before ``tol`` existed takes four arguments: ask for a tolerance only when one is set.
        fit = (
            family.refit(structure, train, start, max_nfev)
            if tol is None
            else family.refit(structure, train, start, max_nfev, tol=tol)
        )
        return fit, family.residual(fit.model, split.test)
    finally:
        forget(train, split.test)


class Scorer:
    """Runs the refits of a diagnosis.

    Parameters
    ----------
    family : Family
        Whose :meth:`~tendon_id.family.Family.refit` and :meth:`~tendon_id.family.Family.residual` run.
    splits : list of Split
    settings : DiagnosisSettings
    n_jobs : int, optional
        joblib workers (1: in this process).
    progress : bool, optional
    tol : float, optional
        Relative tolerance of every refit (:meth:`~tendon_id.family.Family.refit`); default the family's.
    """

    def __init__(self, family, splits, settings, *, n_jobs: int | None = 1, progress: bool | None = None, tol=None):
        self.tol = tol
        self.family = family
        self.splits = splits
        self.settings = settings
        self.n_jobs = 1 if n_jobs is None else int(n_jobs)
        self.progress = progress

    def score(self, structures: list, starts: list[list[tuple]], desc: str) -> list[Score]:
        """Refit each structure on each split from ``starts[structure][split]``."""
        jobs = [
            (self.family, structure, split, starts[i][k], self.settings.max_nfev, self.tol)
            for i, structure in enumerate(structures)
            for k, split in enumerate(self.splits)
        ]
        if self.n_jobs == 1:
            out = [refit_and_score(*job) for job in progress_bar(jobs, desc=desc, enable=self.progress)]
        else:
            from joblib import Parallel, delayed

            gen = Parallel(n_jobs=self.n_jobs, return_as="generator")(delayed(refit_and_score)(*job) for job in jobs)
            out = list(progress_bar(gen, desc=desc, total=len(jobs), enable=self.progress))
        n = len(self.splits)
        scores = []
        for i in range(len(structures)):
            part = out[i * n : (i + 1) * n]
            scores.append(Score([f for f, _ in part], np.concatenate([e for _, e in part])))
        return scores

    def improvement_ci(self, e_before: NDArray, e_after: NDArray, block: int, level: float, rng) -> tuple[float, float]:
        """Block-bootstrap interval of the drop in held-out mean squared error [unit^2]."""
        return improvement_ci(e_before, e_after, block, self.settings.n_boot, level, rng)

    def excess_ci(self, e: NDArray, floor: float, block: int, level: float, rng) -> tuple[float, float]:
        """Block-bootstrap interval of the mean squared error above the noise floor's [unit^2]."""
        excess = frame_mean_squares(e)
        excess -= floor**2
        return bootstrap_ci(excess, block, self.settings.n_boot, level, rng, overwrite_input=True)
