"""``diagnose``: where the gap of a base model lies, which unmodelled effect causes it, and how far it shrinks.

The flow (DESIGN §13):

1. **Base.** The base's structure is refitted on each training split from its own fit
   (:func:`~tendon_id.diagnosis.refit.refit`), so that it and every candidate are fitted
   by the same optimiser and a candidate cannot win by a better optimisation alone.
2. **Where.** Its held-out residual, by stratum (:mod:`~tendon_id.diagnosis.where`), its
   whiteness (Ljung–Box) and its correlation with every candidate's signature.
3. **Which.** Each candidate block is added to the base and refitted from the base fit;
   candidates are ranked by held-out mean squared error.  A candidate counts when the
   block-bootstrap interval of its improvement excludes 0 at ``alpha`` divided by the
   number of candidates.  The training BIC, the confounding of its parameters with the
   law, and the sparse vote on the signature library (:mod:`~tendon_id.diagnosis.library`)
   are reported beside the ranking.
4. **How far.** A greedy ladder adds the best candidate, then the best of the next few on
   top of it, while the improvement stays significant.
5. **Verdict** (:mod:`~tendon_id.diagnosis.verdict`).
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from tendon_id.data import Recording
from tendon_id.diagnosis.ladder import climb
from tendon_id.diagnosis.library import Library, candidate_names
from tendon_id.diagnosis.result import CandidateResult, DiagnosisResult
from tendon_id.diagnosis.runner import Scorer
from tendon_id.diagnosis.settings import DiagnosisSettings
from tendon_id.diagnosis.splits import make_splits, stack
from tendon_id.diagnosis.stats import gap_closed, noise_floor
from tendon_id.diagnosis.verdict import decide
from tendon_id.diagnosis.where import gap_map
from tendon_id.errors import ConfigError
from tendon_id.zoo.blocks import EFFECT_BLOCKS
from tendon_id.zoo.capstan import CapstanModel
from tendon_id.zoo.inputs import as_recordings


def check_base(base) -> CapstanModel:
    """The base model, which must be of the capstan family or a passage one (its blocks are what candidates extend)."""
    from tendon_id.zoo.passage import PassageCapstan

    if not isinstance(base, (CapstanModel, PassageCapstan)):
        name = getattr(base, "name", type(base).__name__)
        raise ConfigError(
            f"the diagnosis extends a capstan-family model with effect blocks; {name!r} is not one "
            "(use capstan-simple, capstan-contact, capstan-nonsmooth or capstan-const-mu, or passage-capstan "
            "for a bench)"
        )
    return base


def diagnose(
    base: CapstanModel,
    train: Recording | Sequence[Recording],
    test: Recording | Sequence[Recording] | None = None,
    candidates: str | Sequence[str] | None = None,
    *,
    settings: DiagnosisSettings | None = None,
    n_jobs: int | None = 1,
    progress: bool | None = None,
) -> DiagnosisResult:
    """Diagnose the gap between a capstan-family base model and measured data.

    Parameters
    ----------
    base : CapstanModel or PassageCapstan
        Fitted or not (an unfitted one is first fitted on ``train``). A passage model is
        diagnosed on bench files by :func:`~tendon_id.diagnosis.passage.diagnose_passage`.
    train : Recording or sequence of Recording
        Training recordings (terminal labels).
    test : Recording or sequence of Recording, optional
        Held-out recordings; without them, blocked cross-validation by trajectory.
    candidates : str or sequence of str, optional
        Candidate effects (DESIGN §5 names), default all; those already in the base are skipped.
    settings : DiagnosisSettings, optional
    n_jobs : int, optional
        Parallel refits (joblib; ``-1``: every core).
    progress : bool, optional
        Progress bar (default: on a terminal).

    Returns
    -------
    DiagnosisResult

    Raises
    ------
    ConfigError
        For a base outside the capstan family, unknown candidates, or too few trajectories.
    """
    from tendon_id.zoo.passage import PassageModel

    if isinstance(base, PassageModel):  # a bench's single passage
        from tendon_id.diagnosis.passage import diagnose_passage

        return diagnose_passage(
            base, train, test, candidates, settings=settings, n_jobs=n_jobs, progress=progress
        )  # fmt: skip
    t0 = time.perf_counter()
    settings = settings or DiagnosisSettings()
    base = check_base(base)
    names = candidate_names(candidates)
    train_recs = as_recordings(train)
    test_recs = as_recordings(test) if test is not None else None
    if not hasattr(base, "A_"):
        base = base.fit(train_recs)
    in_base = {b.effect for b in base.block_objects if b.effect}
    skipped = {n: "already in the base" for n in names if n in in_base}
    names = [n for n in names if n not in in_base]
    splits, validation = make_splits(train_recs, test_recs, base.geometry_, settings.folds)
    rng = np.random.default_rng(settings.seed)
    heldout = stack([s.test for s in splits])
    block = max(int(round(settings.block_s / heldout.dt)), 1)
    scorer = Scorer(splits, settings, n_jobs=n_jobs, progress=progress)

    # Base, refitted per split from its own fit.
    start = (base.A_, base.B_, base.block_params_)
    base_score = scorer.score([base], [[start] * len(splits)], "refit base")[0]
    e0 = base_score.residual
    mse0 = float(np.nanmean(e0**2))
    floor_sim = noise_floor(
        splits[0].noise,
        base_score.fits[0].model,
        heldout,
        e0,
        rng,
        draws=settings.floor_draws,
        level=1 - settings.alpha,
    )
    floor = floor_sim.rmse

    # Candidates: localised on all training data with the base fit, then refitted per split.  One that
    # refines an effect the base lacks (smooth_edge of stick_slip) waits for the ladder to add it.
    full_train = splits[0].train if test_recs is not None else heldout  # CV: the held-out folds are all of it
    resid_train = full_train.terminal - base.terminal_reading(full_train, *start)
    later = [n for n in names if not eligible(n, in_base)]
    skipped.update(
        {n: f"refines {', '.join(EFFECT_BLOCKS[n].requires)}: tried on the ladder once that is in" for n in later}
    )
    all_blocks = {n: EFFECT_BLOCKS[n].localise(base, full_train, *start, resid_train) for n in names if n not in later}
    all_blocks.update({n: EFFECT_BLOCKS[n]() for n in later})
    names = [n for n in names if n not in later]
    blocks = {n: all_blocks[n] for n in names}
    structures = [base.with_blocks(b) for b in blocks.values()]
    starts = [[(f.model.A_, f.model.B_, f.model.block_params_) for f in base_score.fits] for _ in structures]
    scores = scorer.score(structures, starts, "refit candidates")
    level = 1.0 - 2.0 * settings.alpha / max(len(names), 1)
    results = []
    for (effect, blk), sc in zip(blocks.items(), scores):
        ci = scorer.improvement_ci(e0, sc.residual, block, level, rng)
        mse = float(np.nanmean(sc.residual**2))
        fitted = sc.fits[0].model
        params = fitted.block_values_.get(blk.name, {})
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
                location=_location(blk),
                confounded=tuple(_confounded(sc.fits[0], blk.name, settings.confound_corr)),
                at_bound=tuple(_at_bound(blk, sc.fits)),
            )
        )
    order = sorted(range(len(results)), key=lambda i: results[i].heldout_rmse)
    ranked = [results[i] for i in order]

    # Where, and the library of signatures on the held-out frames.
    law = base_score.fits[0].model  # the signatures are shapes, not magnitudes: one split's law will do
    library = Library.build(blocks, base, heldout, law.A_, law.B_, base.block_params_)
    where = gap_map(heldout, e0, block=block, n_boot=settings.n_boot, level=1 - settings.alpha, rng=rng)

    # How far: the ladder.
    def remaining(chosen: list[str]) -> list[str]:
        have = in_base | {all_blocks[e].effect for e in chosen}
        out = [c.effect for c in ranked if c.effect not in chosen]
        return out + [n for n in later if n not in chosen and eligible(n, have)]

    run = climb(
        ranked,
        {e: (st, sc) for e, st, sc in zip(blocks, structures, scores)},
        base_score,
        scorer=scorer,
        settings=settings,
        mse0=mse0,
        floor=floor,
        block=block,
        rng=rng,
        remaining=remaining,
        screen=lambda score, cands: _screen(score, splits[0].train, cands, all_blocks),
        extend=lambda structure, e: structure.with_blocks(all_blocks[e]),
        start=lambda model, single, k: _merge(model, single.fits[k].model if single is not None else None),
    )
    ladder = run.ladder
    excess_ci = scorer.excess_ci(e0, floor, block, 1 - 2 * settings.alpha, rng)
    strained = {c.effect for c in ranked if c.at_bound}
    structural = {e for e, b in blocks.items() if not b.param_names}
    verdict = decide(mse0, floor_sim, excess_ci, ladder, settings, strained, structural)
    return DiagnosisResult.assemble(
        residual=e0,
        floor=floor_sim,
        library=library,
        ranked=ranked,
        rng=rng,
        heldout_frames=heldout.n_frames,
        base=base.name,
        validation=validation,
        n_train=int(splits[0].train.n_frames),
        where=where,
        skipped=skipped,
        ladder=ladder,
        verdict=verdict,
        model=run.score.fits[0].model,
        seconds=time.perf_counter() - t0,
    )


def _location(block) -> str:
    guides = getattr(block, "guides", ())
    return f"guide{'s' if len(guides) > 1 else ''} {', '.join(map(str, guides))}" if guides else ""


def _confounded(fit, block_name: str, threshold: float) -> list[str]:
    """Block parameters whose correlation with a law parameter exceeds ``threshold``."""
    if fit.corr is None:
        return []
    out = []
    law = [i for i, lab in enumerate(fit.labels) if ":" in lab and "[" in lab.split(":")[0]]
    for j, lab in enumerate(fit.labels):
        if lab.startswith(f"{block_name}:"):
            k = max(law, key=lambda i: abs(fit.corr[j, i]))
            if abs(fit.corr[j, k]) > threshold:
                out.append(
                    f"{lab.split(':', 1)[1]} correlates {fit.corr[j, k]:+.2f} with the law's {fit.labels[k]}: "
                    "the data cannot tell them apart well (confounded)"
                )
    return out


def _screen(score, train, remaining: list[str], blocks: dict) -> list[str]:
    """The remaining candidates in the order their signatures correlate with the rung's training residual.

    After an effect is added, what is left of the residual shows the next one; screening by
    correlation (as in forward stepwise regression) picks which few to refit.  Training data
    only: the held-out frames judge, they do not choose.
    """
    if len(remaining) <= 1:
        return remaining
    model = score.fits[0].model
    law = (model.A_, model.B_, model.block_params_)
    resid = train.terminal - model.terminal_reading(train, *law)
    library = Library.build({e: blocks[e] for e in remaining}, model, train, *law)
    corr = library.effect_correlation(resid)
    return sorted(remaining, key=lambda e: -corr.get(e, 0.0))


def _at_bound(block, fits, rel: float = 1e-3) -> list[str]:
    """Parameters of ``block`` fitted onto a bound of their range other than the neutral (effect-off) end."""
    neutral = block.initial()
    out = []
    for p in block.param_names:
        lo, hi = block.bounds[p]
        tol = rel * (hi - lo)
        for f in fits:
            v = f.model.block_values_.get(block.name, {}).get(p)
            if v is None:
                continue
            at_lo = abs(v - lo) <= tol and abs(neutral[p] - lo) > tol
            at_hi = abs(v - hi) <= tol and abs(neutral[p] - hi) > tol
            if at_lo or at_hi:
                out.append(p)
                break
    return out


def _merge(current, single) -> tuple:
    """Start of a ladder refit: the current rung's fit, and the candidate's own fitted block values, if any."""
    values = dict(current.block_params_)
    if single is not None:
        values.update({k: v for k, v in single.block_params_.items() if k not in values})
    return current.A_, current.B_, values


def eligible(effect: str, present: set) -> bool:
    """Whether candidate ``effect`` can be added to a model with the effects ``present`` (what it refines is in)."""
    return all(r in present for r in EFFECT_BLOCKS[effect].requires)
