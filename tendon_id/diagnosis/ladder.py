"""How far: the greedy ladder of effects, shared by the snake's diagnosis and a bench's.

The ladder starts from the best-ranked significant candidate. At each rung the remaining
candidates are screened on the training residual, the best few (``ladder_width``) are refitted
on top of the current structure, and the best of those is kept while its held-out improvement
is significant (a block bootstrap, Bonferroni over the rung's trials), as in forward stepwise
selection. Each family supplies what differs: which candidates remain, how they are screened,
how a structure grows by one effect, and where a refit starts.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from tendon_id.diagnosis.moments import nan_mean_square
from tendon_id.diagnosis.result import CandidateResult, Rung
from tendon_id.diagnosis.runner import Score, Scorer
from tendon_id.diagnosis.settings import DiagnosisSettings
from tendon_id.diagnosis.stats import gap_closed


@dataclass
class Climb:
    """The ladder's outcome.

    Attributes
    ----------
    ladder : list of Rung
        The base, then one rung per accepted effect.
    chosen : list of str
        The accepted effects, in order.
    scores : list of Score
        Each accepted rung's refit score (aligned with ``chosen``).
    score : Score
        The last rung's score (the base's when nothing was accepted).
    """

    ladder: list
    chosen: list
    scores: list
    score: Score


def climb(
    ranked: list[CandidateResult],
    first: dict[str, tuple[object, Score]],
    base_score: Score,
    *,
    scorer: Scorer,
    settings: DiagnosisSettings,
    mse0: float,
    floor: float,
    block: int,
    rng: np.random.Generator,
    remaining: Callable[[list[str]], list[str]],
    screen: Callable[[Score, list[str]], list[str]],
    extend: Callable[[object, str], object],
    start: Callable[[object, Score | None, int], object],
    min_gain: float = 0.0,
) -> Climb:
    """Climb the ladder from the ranked candidates.

    Parameters
    ----------
    ranked : list of CandidateResult
        The first ranking, best first.
    first : dict
        ``{effect: (structure, score)}`` of the first ranking's refits.
    base_score : Score
        The base's refit.
    scorer, settings, mse0, floor, block, rng :
        The diagnosis's scorer and settings, the base's held-out mean squared error, the noise
        floor [N or N m], the bootstrap block [frames] and generator.
    remaining : callable
        ``remaining(chosen)``: the candidates that may be added to a model with ``chosen``.
    screen : callable
        ``screen(score, candidates)``: them in the order to try on top of ``score``'s fit.
    extend : callable
        ``extend(structure, effect)``: an unfitted structure with ``effect`` added.
    start : callable
        ``start(fitted_model, single_score, k)``: split ``k``'s refit start, from the current
        rung's fit and the candidate's own first-ranking score (None if it had none).
    min_gain : float
        Share of the gap a rung must close besides being significant (0: significance alone).
    """
    ladder = [Rung(["base"], float(np.sqrt(mse0)), 0.0)]
    out = Climb(ladder, [], [], base_score)
    if not (ranked and ranked[0].significant):
        return out
    top = ranked[0]
    structure, score = first[top.effect]
    out.chosen, out.scores, out.score = [top.effect], [score], score
    ladder.append(Rung(["base", top.effect], top.heldout_rmse, top.gap_closed, top.improvement_ci))
    while len(out.chosen) < settings.max_rungs:
        trial = screen(score, remaining(out.chosen))[: settings.ladder_width]
        if not trial:
            break
        structs = [extend(structure, e) for e in trial]
        singles = [first[e][1] if e in first else None for e in trial]
        starts = [[start(f.model, single, k) for k, f in enumerate(score.fits)] for single in singles]
        trial_scores = scorer.score(structs, starts, f"ladder rung {len(out.chosen) + 1}")
        best = int(np.argmin([nan_mean_square(s.residual) for s in trial_scores]))
        level = 1 - 2 * settings.alpha / len(trial)
        ci = scorer.improvement_ci(score.residual, trial_scores[best].residual, block, level, rng)
        mse = nan_mean_square(trial_scores[best].residual)
        closed = gap_closed(mse0, mse, floor)
        if not ci[0] > 0 or (min_gain > 0 and closed - ladder[-1].gap_closed < min_gain):
            break
        structure, score = structs[best], trial_scores[best]
        out.chosen.append(trial[best])
        out.scores.append(score)
        out.score = score
        ladder.append(Rung(["base", *out.chosen], float(np.sqrt(mse)), closed, ci))
    return out
