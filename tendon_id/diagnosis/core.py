"""``diagnose``: where the gap of a base model lies, which unmodelled effect causes it, and how far it shrinks.

Written once for every transmission family (:doc:`/guide/diagnosis`); the family supplies its
data, blocks, refits, strata, signatures and noise floor (:mod:`tendon_id.family`). The flow:

1. **Base.** The base's structure is refitted on each training split from its own fit
   (:meth:`~tendon_id.family.Family.refit`), so that it and every candidate are fitted by the
   same optimiser and a candidate cannot win by a better optimisation alone.
2. **Where.** Its held-out residual, by stratum (:mod:`~tendon_id.diagnosis.where`), its
   whiteness (Ljung–Box) and its correlation with every candidate's signature.
3. **Which.** Each candidate block is added to the base and refitted from the base fit;
   candidates are ranked by held-out mean squared error.  A candidate counts when the
   block-bootstrap interval of its improvement excludes 0 at ``alpha`` divided by the
   number of candidates.  The training BIC, the confounding of its parameters with the
   law, and the sparse vote on the signature library (:mod:`~tendon_id.diagnosis.library`)
   are reported beside the ranking.
4. **How far.** A greedy ladder adds the best candidate (the simplest of it and its rivals,
   :func:`~tendon_id.diagnosis.verdict.parsimonious_lead`), then the best of the next few on
   top of it, while the improvement stays significant (:mod:`~tendon_id.diagnosis.ladder`).
5. **Null gains.** Where the floor alone shows no gap, the ladder's first rung is refitted on
   data simulated from the base's fit, and must gain more than it gains there
   (:mod:`~tendon_id.diagnosis.calibrate`).
6. **Verdict** (:mod:`~tendon_id.diagnosis.verdict`).
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from tendon_id.checks import check_jobs
from tendon_id.data.io import release_arrow_memory
from tendon_id.diagnosis.calibrate import calibrated_margins
from tendon_id.diagnosis.ladder import climb
from tendon_id.diagnosis.library import candidate_names
from tendon_id.diagnosis.moments import nan_mean_square
from tendon_id.diagnosis.result import CandidateResult, DiagnosisResult
from tendon_id.diagnosis.runner import Scorer
from tendon_id.diagnosis.settings import DiagnosisSettings
from tendon_id.diagnosis.stats import gap_closed
from tendon_id.diagnosis.verdict import decide, parsimonious_lead, read_ladder, with_rivals, within_sensors
from tendon_id.diagnosis.where import gap_map
from tendon_id.errors import ConfigError
from tendon_id.family.fit import Fit
from tendon_id.family.inputs import forget
from tendon_id.family.registry import family_of

__all__ = ["check_base", "diagnose"]


def check_base(base):
    """The base model, if its family's diagnosis can extend it with effect blocks (ConfigError otherwise)."""
    family_of(base).check_base(base)
    return base


def diagnose(
    base,
    train,
    test=None,
    candidates: str | Sequence[str] | None = None,
    *,
    settings: DiagnosisSettings | None = None,
    n_jobs: int | None = 1,
    progress: bool | None = None,
) -> DiagnosisResult:
    """Diagnose the gap between a base model and measured data.

    Parameters
    ----------
    base : Estimator
        A model composed of effect blocks (a capstan model of the snake chain, a passage model
        of a bench), fitted or not (an unfitted one is first fitted on ``train``).
    train : recording or sequence of them
        Training recordings of the base's family.
    test : recording or sequence of them, optional
        Held-out recordings; without them, the family's blocked cross-validation (by
        trajectory for the snake chain, by file for a bench).
    candidates : str or sequence of str, optional
        Candidate effects among the family's blocks, default all; those already in the base are skipped.
    settings : DiagnosisSettings, optional
    n_jobs : int, optional
        Parallel refits (joblib; ``-1``: every core).
    progress : bool, optional
        Progress bar (default: on a terminal).

    Returns
    -------
    DiagnosisResult
        Its errors in the family's unit (N, or N m for a torque passage).

    Raises
    ------
    ConfigError
        For a base without blocks, unknown candidates, or too few trajectories or files.
    """
    t0 = time.perf_counter()
    n_jobs = 1 if n_jobs is None else check_jobs("n_jobs", n_jobs)
    family = family_of(base)
    settings = settings or DiagnosisSettings()
    family.check_base(base)
    names = candidate_names(candidates, family.blocks)
    train_recs = family.recordings(train, "train")
    test_recs = family.recordings(test, "test") if test is not None else None
    if not base.is_fitted and family.splits_read_the_fit:
        base = base.fit(train_recs)
    in_base = family.effects(base)
    skipped = {n: "already in the base" for n in names if n in in_base}
    names = [n for n in names if n not in in_base]
    if any(family.blocks[n].needs for n in names):
        full = family.inputs(train_recs)
        for n in names:
            missing = family.blocks[n]().missing(full)
            if missing:
                skipped[n] = f"needs the {', '.join(missing)} column, which the data lack"
        names = [n for n in names if n not in skipped]
    splits, validation = family.splits(train_recs, test_recs, settings.folds, base)
    # Nothing past here reads the recordings: a caller that passed them on (the CLI) frees them for
    # the refits, which read the splits' stacked signals.
    truth, held_given = simulator_truth(train_recs[0]), test_recs is not None
    train = test = train_recs = test_recs = full = None
    release_arrow_memory()  # their text columns lived in Arrow's allocator
    rng = np.random.default_rng(settings.seed)
    heldout = type(splits[0].test).concat([s.test for s in splits])
    if not base.is_fitted:  # on the stacked signals, the same arrays, with the recordings let go
        base = base.fit(splits[0].training() if held_given else heldout)  # CV: the held-out folds are all of it
        forget(heldout)
    block = max(int(round(settings.block_s / heldout.dt)), 1)
    scorer = Scorer(family, splits, settings, n_jobs=n_jobs, progress=progress)

    # Base, refitted per split from its own fit.
    base_score = scorer.score([base], [[family.start(base)] * len(splits)], "refit base")[0]
    e0 = base_score.residual
    mse0 = nan_mean_square(e0)
    floor_sim = family.noise_floor(splits[0], base_score.fits[0].model, heldout, e0, rng, settings)
    floor = floor_sim.rmse

    # Candidates: placed on all training data with the base fit, then refitted per split.  One that
    # refines an effect the base lacks (smooth_edge of stick_slip) waits for the ladder to add it.
    later = [n for n in names if not eligible(family, n, in_base)]
    skipped.update(
        {n: f"refines {', '.join(family.blocks[n].requires)}: tried on the ladder once that is in" for n in later}
    )
    names = [n for n in names if n not in later]
    full_train = splits[0].training() if held_given else heldout  # CV: the held-out folds are all of it
    blocks = family.candidates(base, full_train, names)
    clash = [n for n, b in blocks.items() if not composes(base, [b])]
    skipped.update({n: "does not compose with the base's blocks" for n in clash})
    blocks = {n: b for n, b in blocks.items() if n not in clash}
    names = [n for n in names if n not in clash]
    all_blocks = {**blocks, **{n: family.blocks[n]() for n in later}}
    structures = [base.with_blocks(b) for b in blocks.values()]
    starts = [[family.start(f.model) for f in base_score.fits] for _ in structures]
    scores = scorer.score(structures, starts, "refit candidates")
    level = 1.0 - 2.0 * settings.alpha / max(len(names), 1)
    results = []
    for (effect, blk), sc in zip(blocks.items(), scores):
        ci = scorer.improvement_ci(e0, sc.residual, block, level, rng)
        mse = nan_mean_square(sc.residual)
        params = family.block_values(sc.fits[0].model, blk)
        results.append(
            CandidateResult(
                effect=effect,
                block={**blk.to_dict(), **params},
                heldout_rmse=float(np.sqrt(mse)),
                gap_closed=gap_closed(mse0, mse, floor),
                improvement_ci=ci,
                significant=ci[0] > 0,
                ic_delta=float(sum(f.bic() for f in sc.fits) - sum(f.bic() for f in base_score.fits)),
                params=params,
                location=blk.location(),
                confounded=tuple(confounded(sc.fits[0], blk.name, settings.confound_corr)),
                at_bound=tuple(at_bound(blk, sc.fits)),
            )
        )
    order = sorted(range(len(results)), key=lambda i: results[i].heldout_rmse)
    ranked = [results[i] for i in order]

    # Where, on the held-out frames.
    where = gap_map(
        heldout, e0, family.strata(heldout), block=block, n_boot=settings.n_boot, level=1 - settings.alpha, rng=rng
    )
    forget(heldout)  # its derived arrays, computed again if the end's noise floor needs them

    # How far: the ladder.
    def remaining(chosen: list[str]) -> list[str]:
        have = in_base | {all_blocks[e].effect for e in chosen}
        out = [c.effect for c in ranked if c.effect not in chosen]
        out += [n for n in later if n not in chosen and eligible(family, n, have)]
        return [n for n in out if composes(base, [all_blocks[e] for e in chosen] + [all_blocks[n]])]

    run = climb(
        parsimonious_lead(ranked, settings),
        {e: (st, sc) for e, st, sc in zip(blocks, structures, scores)},
        base_score,
        scorer=scorer,
        settings=settings,
        mse0=mse0,
        floor=floor,
        block=block,
        rng=rng,
        remaining=remaining,
        screen=lambda score, cands: screen(family, score, splits[0].training(), cands, all_blocks),
        extend=lambda structure, e: structure.with_blocks(all_blocks[e]),
        start=lambda model, single, k: family.merge(model, single.fits[k].model if single is not None else None),
        min_gain=family.min_rung_gain if settings.min_rung_gain is None else settings.min_rung_gain,
    )
    ladder = run.ladder
    excess_ci = scorer.excess_ci(e0, floor, block, 1 - 2 * settings.alpha, rng)
    strained = {c.effect for c in ranked if c.at_bound}
    strained |= {e for e, sc in zip(run.chosen[1:], run.scores[1:]) if at_bound(all_blocks[e], sc.fits)}
    structural = {e for e, b in all_blocks.items() if not b.param_names}
    unit = family.unit(heldout)
    margins, null, draws = None, [], None
    if (
        len(ladder) > 1
        and settings.null_draws
        and not (excess_ci[0] > 0 and not within_sensors(mse0, floor_sim, settings))
    ):
        # The floor alone shows no gap, so the paired test decides: calibrate it on data simulated from the base.
        calibrated = calibrated_margins(
            family, splits, base, base_score, run, all_blocks, settings, rng,
            n_candidates=len(names), n_jobs=n_jobs, progress=progress,
        )  # fmt: skip
        if calibrated is not None:
            gain, draws = calibrated
            margins, null = [gain.margin], [gain]
    end_floor = None
    if 1 < len(read_ladder(ladder, strained)) == len(ladder) and not within_sensors(
        ladder[-1].heldout_rmse ** 2, floor_sim, settings
    ):
        # The end model's own floor (one that undoes a lag on its inputs amplifies their noise), on the
        # very draws of the base's floor (a generator of the same seed, whose first use that was), so
        # that only the model differs and every other draw of the diagnosis stays as it was.
        end_rng = np.random.default_rng(settings.seed)
        end_model = run.score.fits[0].model
        end_floor = family.noise_floor(splits[0], end_model, heldout, run.score.residual, end_rng, settings)
    verdict = decide(
        mse0, floor_sim, excess_ci, ladder, settings, strained, structural,
        unit=unit, margins=margins, end_floor=end_floor,
    )  # fmt: skip
    verdict = with_rivals(verdict, ranked, settings)
    # The library of signatures last: its columns (a whole-length array per candidate) are not held
    # through the ladder's refits, nor beside the candidates' residuals, which are let go first (only
    # the base's is reported). The signatures are shapes, not magnitudes: one split's law will do.
    final_model, law = run.score.fits[0].model, base_score.fits[0].model
    run = scores = base_score = None
    library = family.signatures(base, law, heldout, blocks)
    forget(heldout)
    return DiagnosisResult.assemble(
        residual=e0,
        floor=floor_sim,
        library=library,
        ranked=ranked,
        rng=rng,
        heldout_frames=heldout.n_frames,
        base=base.name,
        validation=validation,
        n_train=int(splits[0].train.n_frames),  # a Stacked counts its frames without stacking them
        where=where,
        skipped=skipped,
        ladder=ladder,
        verdict=verdict,
        model=final_model,
        seconds=time.perf_counter() - t0,
        unit=unit,
        truth=truth,
        null_gains=null,
        null_draws=draws,
    )


#: The metadata keys in which a simulated recording states its truth (:doc:`/guide/simulator`).
TRUTH_KEYS = ("recipe", "effects", "options", "effect_params", "friction_truth", "session")


def simulator_truth(rec) -> dict | None:
    """What the simulator put into ``rec`` (its recipe, law and effects), or None for real data."""
    meta = getattr(rec, "meta", None) or {}
    if meta.get("friction_truth") is None:
        return None
    return {k: meta[k] for k in TRUTH_KEYS if k in meta}


def composes(base, blocks: list) -> bool:
    """Whether ``blocks`` can be added to ``base`` together (a block that acts on every guide at once, say,
    does not compose with one that acts on one guide's output): the ladder does not try those that cannot."""
    try:
        base.with_blocks(*blocks).block_objects  # noqa: B018 - a model composes its blocks when they are read
    except ConfigError:
        return False
    return True


def eligible(family, effect: str, present: set) -> bool:
    """Whether candidate ``effect`` can be added to a model with the effects ``present`` (what it refines is in)."""
    return all(r in present for r in family.blocks[effect].requires)


def confounded(fit: Fit, block_name: str, threshold: float) -> list[str]:
    """Parameters of block ``block_name`` whose correlation with a law parameter exceeds ``threshold``."""
    if fit.corr is None or fit.n_law == 0:
        return []
    out = []
    for j, lab in enumerate(fit.labels):
        if lab.startswith(f"{block_name}:"):
            k = max(range(fit.n_law), key=lambda i: abs(fit.corr[j, i]))
            if abs(fit.corr[j, k]) > threshold:
                out.append(
                    f"{lab.split(':', 1)[1]} correlates {fit.corr[j, k]:+.2f} with the law's {fit.labels[k]}: "
                    "the data cannot tell them apart well (confounded)"
                )
    return out


def at_bound(block, fits: list[Fit], rel: float = 1e-3) -> list[str]:
    """Parameters of ``block`` fitted onto a bound of their range other than the neutral (effect-off) end."""
    neutral = block.neutral()
    out = []
    for p in block.param_names:
        label = f"{block.name}:{p}"
        for f in fits:
            values = getattr(f.model, "block_params_", {}).get(block.name, {})
            if label not in f.labels or p in block.inert(values):
                continue
            k = f.labels.index(label)
            lo, hi, v = float(f.lower[k]), float(f.upper[k]), float(f.x[k])
            tol = rel * (hi - lo)
            at_lo = abs(v - lo) <= tol and abs(neutral[p] - lo) > tol
            at_hi = abs(v - hi) <= tol and abs(neutral[p] - hi) > tol
            if at_lo or at_hi:
                out.append(p)
                break
    return out


def screen(family, score, train, remaining: list[str], blocks: dict) -> list[str]:
    """The remaining candidates in the order their signatures correlate with the rung's training residual.

    After an effect is added, what is left of the residual shows the next one; screening by
    correlation (as in forward stepwise regression) picks which few to refit.  Training data
    only: the held-out frames judge, they do not choose.
    """
    if len(remaining) <= 1:
        return remaining
    model = score.fits[0].model
    resid = family.residual(model, train)
    library = family.signatures(model, model, train, {e: blocks[e] for e in remaining})
    corr = library.effect_correlation(resid)
    return sorted(remaining, key=lambda e: -corr.get(e, 0.0))
