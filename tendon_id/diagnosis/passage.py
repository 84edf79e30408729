"""The diagnosis of a single passage on a bench: the same where / which / how far / verdict as the snake's.

The flow is :mod:`tendon_id.diagnosis.core`'s, with the passage family's parts:

* **Splits by file.** A held-out set of files, or blocked cross-validation over files: a
  file is never split, since a bench's samples are correlated over seconds.
* **Refits** by :func:`~tendon_id.zoo.passage.fitting.calibrate_passage`, the base on each
  split from its fit on all the training files, each candidate from that split's base fit.
* **Candidates** are the passage blocks (:data:`~tendon_id.zoo.passage.blocks.PASSAGE_BLOCKS`).
  A block that refines another (``smooth_edge`` refines ``stick_slip``) is tried on the
  ladder once what it refines is in; one that reads a signal the data lack is skipped.
* **Where**: near reversals, by load, by speed, by position, since a log's start.
* **Signatures**: a block's change of the prediction at its probe values, the residual's
  first-order shape where that block is missing.
* **The noise floor** comes from the residual's first differences (a bench declares no
  sensor noise).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from friction_models import play_operator
from tendon_id.diagnosis.ladder import climb
from tendon_id.diagnosis.library import Library, candidate_names
from tendon_id.diagnosis.refit import Fit
from tendon_id.diagnosis.result import CandidateResult, DiagnosisResult
from tendon_id.diagnosis.runner import Score, Scorer
from tendon_id.diagnosis.settings import DiagnosisSettings
from tendon_id.diagnosis.stats import difference_floor, gap_closed
from tendon_id.diagnosis.verdict import decide
from tendon_id.diagnosis.where import gap_map, quartile_masks
from tendon_id.errors import ConfigError
from tendon_id.zoo.passage import PASSAGE_BLOCKS, PassageCapstan
from tendon_id.zoo.passage.fitting import calibrate_passage, data_scales
from tendon_id.zoo.passage.inputs import PassageInputs, as_passages

#: Share of the travel's range the input must move back after a reversal to leave the
#: "near reversals" stratum [-].
REVERSAL_SHARE = 0.05
UNITS = {"torque": "N m", "tension": "N"}


@dataclass(frozen=True)
class PassageSplit:
    """One training/held-out pair of passage inputs."""

    train: PassageInputs
    test: PassageInputs


def file_splits(train: list, test: list | None, folds: int) -> tuple[list[PassageSplit], str]:
    """Held-out files, or blocked cross-validation over the training files (never within a file)."""
    if test is not None:
        return [PassageSplit(PassageInputs.from_recordings(train), PassageInputs.from_recordings(test))], (
            f"held-out files ({len(train)} for fitting, {len(test)} held out)"
        )
    if len(train) < 2:
        raise ConfigError("cross-validation by file needs two or more files; give held-out files with --test")
    k = min(folds, len(train))
    groups = np.array_split(np.arange(len(train)), k)
    splits = [
        PassageSplit(
            PassageInputs.from_recordings([r for i, r in enumerate(train) if i not in g]),
            PassageInputs.from_recordings([train[i] for i in g]),
        )
        for g in groups
    ]
    return splits, f"{k}-fold cross-validation by file ({len(train)} files)"


def _task(structure, train, test, start, max_nfev):
    """Refit ``structure`` on ``train`` from ``start``; its held-out residual (NaN in the warm-up), shape (T, 1)."""
    model = type(structure)(**{**structure.get_params(), "maxeval": max(int(max_nfev), structure.maxeval)})
    fit = calibrate_passage(model, train, start=start)
    model.theta_, model.quantity_, model.calibration_ = dict(fit.theta), train.quantity, fit.summary()
    e = model.target(test) - model.reading(test, model.theta_)
    e[test.since_start < float(model.warmup_s)] = np.nan
    refitted = Fit(
        model, fit.rmse**2 * fit.n_obs, fit.n_obs, len(fit.labels), fit.labels, fit.corr, fit.n_eval, fit.seconds
    )
    return refitted, e[:, None]


def passage_strata(inputs: PassageInputs) -> list[tuple[str, str, NDArray]]:
    """``(name, kind, mask)`` of a bench's strata: near reversals, load, speed, position, time since start."""
    x = inputs.travel()
    band = REVERSAL_SHARE * float(np.ptp(x))
    stuck = play_operator(x, band, inputs.reset).sigma == 0 if band > 0 else np.zeros(x.shape, bool)
    out = [("near reversals", "reversal", stuck), ("away from reversals", "reversal", ~stuck)]
    unit = UNITS[inputs.quantity]
    out += [(n, "load", m) for n, m in quartile_masks(np.abs(inputs.output), "output load", unit)]
    speed = np.abs(inputs.speed())
    rest = "input at rest" if speed.min() == 0 else None
    out += [(n, "speed", m) for n, m in quartile_masks(speed, "input speed", "rad/s", least=rest)]
    if inputs.position is not None:
        angle = inputs.position_out if inputs.position_out is not None else inputs.position
        out += [(n, "position", m) for n, m in quartile_masks(angle, "position", "rad")]
    out += [(n, "start", m) for n, m in quartile_masks(inputs.since_start, "time since log start", "s")]
    return out


def signatures(model: PassageCapstan, theta: dict, effects: list[str], inputs: PassageInputs) -> Library:
    """Each effect's change of the prediction when added to ``model`` at its probe values, shape (T, 1, C)."""
    scale = data_scales(inputs)
    base = model.reading(inputs, theta)
    labels, cols = [], []
    for e in effects:
        block = PASSAGE_BLOCKS[e]()
        probe = {f"{e}:{p}": v for p, v in block.probe(scale).items()}
        cols.append(model.with_blocks(e).reading(inputs, {**theta, **probe}) - base)
        labels.append(e)
    columns = np.stack(cols, axis=-1)[:, None, :] if cols else np.zeros((inputs.n_frames, 1, 0))
    return Library(labels, list(labels), columns)


def _eligible(names: list[str], chosen: Sequence[str]) -> list[str]:
    return [n for n in names if n not in chosen and all(r in chosen for r in PASSAGE_BLOCKS[n].requires)]


def _at_bound(effect: str, fits: list[Fit], rel: float = 1e-3) -> list[str]:
    """Parameters of ``effect`` fitted onto the bound of their range that is not the neutral (effect-off) one."""
    block = PASSAGE_BLOCKS[effect]()
    out = []
    for p, neutral in block.neutral().items():
        label = f"{effect}:{p}"
        for f in fits:
            (lo, hi), v = f.model.calibration_["bounds"][label], f.model.theta_[label]
            tol = rel * (hi - lo)
            if (abs(v - lo) <= tol and abs(neutral - lo) > tol) or (abs(v - hi) <= tol and abs(neutral - hi) > tol):
                out.append(p)
                break
    return out


def _confounded(fit, effect: str, threshold: float) -> list[str]:
    """Parameters of ``effect`` whose correlation with a law parameter exceeds ``threshold``."""
    if fit.corr is None:
        return []
    law = [i for i, lab in enumerate(fit.labels) if ":" not in lab]
    out = []
    for j, lab in enumerate(fit.labels):
        if lab.startswith(f"{effect}:") and law:
            k = max(law, key=lambda i: abs(fit.corr[j, i]))
            if abs(fit.corr[j, k]) > threshold:
                out.append(
                    f"{lab.split(':', 1)[1]} correlates {fit.corr[j, k]:+.2f} with the law's {fit.labels[k]}: "
                    "the data cannot tell them apart well (confounded)"
                )
    return out


def diagnose_passage(
    base: PassageCapstan,
    train,
    test=None,
    candidates: str | Sequence[str] | None = None,
    *,
    settings: DiagnosisSettings | None = None,
    n_jobs: int | None = 1,
    progress: bool | None = None,
) -> DiagnosisResult:
    """Diagnose the gap between a passage model and bench recordings (see the module docstring).

    Parameters
    ----------
    base : PassageCapstan
        Fitted or not (an unfitted one is first fitted on ``train``).
    train, test : PassageRecording or sequence of them
        Files for fitting, and held-out files (without them: cross-validation by file).
    candidates : str or sequence of str, optional
        Passage effects (default all); those in the base are skipped.
    settings : DiagnosisSettings, optional
    n_jobs : int, optional
        Parallel refits (joblib).
    progress : bool, optional

    Returns
    -------
    DiagnosisResult
        With ``unit`` the passage's (N m or N).
    """
    t0 = time.perf_counter()
    settings = settings or DiagnosisSettings()
    names = candidate_names(candidates, PASSAGE_BLOCKS)
    train_recs = as_passages(train)
    test_recs = as_passages(test) if test is not None else None
    full = PassageInputs.from_recordings(train_recs)
    if not base.is_fitted:
        base = base.fit(full)
    in_base = set(base.blocks)
    skipped = {n: "already in the base" for n in names if n in in_base}
    for n in names:
        block = PASSAGE_BLOCKS[n]()
        missing = [need for need in block.needs if getattr(full, need) is None]
        if n not in in_base and missing:
            skipped[n] = f"needs the {', '.join(missing)} column, which the data lack"
    names = [n for n in names if n not in skipped]
    splits, validation = file_splits(train_recs, test_recs, settings.folds)
    rng = np.random.default_rng(settings.seed)
    heldout = PassageInputs.concat([s.test for s in splits])
    block = max(int(round(settings.block_s / heldout.dt)), 1)
    scorer = Scorer(splits, settings, n_jobs=n_jobs, progress=progress, task=_task)

    base_score = scorer.score([base], [[base.theta_] * len(splits)], "refit base")[0]
    e0 = base_score.residual
    mse0 = float(np.nanmean(e0**2))
    floor_sim = difference_floor(e0)
    floor = floor_sim.rmse

    first = _eligible(names, base.blocks)
    for n in names:
        if n not in first:
            skipped[n] = f"refines {', '.join(PASSAGE_BLOCKS[n].requires)}: tried on the ladder once that is in"
    structures = [base.with_blocks(n) for n in first]
    starts = [[f.model.theta_ for f in base_score.fits] for _ in structures]
    scores = scorer.score(structures, starts, "refit candidates")
    level = 1.0 - 2.0 * settings.alpha / max(len(first), 1)
    results, strained = [], set()
    for effect, sc in zip(first, scores):
        ci = scorer.improvement_ci(e0, sc.residual, block, level, rng)
        mse = float(np.nanmean(sc.residual**2))
        params = {p: sc.fits[0].model.theta_[f"{effect}:{p}"] for p in PASSAGE_BLOCKS[effect].param_names}
        at_bound = tuple(_at_bound(effect, sc.fits))
        strained |= {effect} if at_bound else set()
        results.append(
            CandidateResult(
                effect=effect,
                block={"effect": effect, **params},
                heldout_rmse=float(np.sqrt(mse)),
                gap_closed=gap_closed(mse0, mse, floor),
                improvement_ci=ci,
                significant=ci[0] > 0,
                ic_delta=float(sum(f.bic() for f in sc.fits) - sum(f.bic() for f in base_score.fits)),
                params=params,
                confounded=tuple(_confounded(sc.fits[0], effect, settings.confound_corr)),
                at_bound=at_bound,
            )
        )
    order = sorted(range(len(results)), key=lambda i: results[i].heldout_rmse)
    ranked = [results[i] for i in order]

    law = base_score.fits[0].model
    library = signatures(law, law.theta_, first, heldout)
    where = gap_map(
        heldout, e0, block=block, n_boot=settings.n_boot, level=1 - settings.alpha, rng=rng,
        masks=passage_strata(heldout),
    )  # fmt: skip

    # How far: the greedy ladder, as the snake's.
    run = climb(
        ranked,
        {e: (st, sc) for e, st, sc in zip(first, structures, scores)},
        base_score,
        scorer=scorer,
        settings=settings,
        mse0=mse0,
        floor=floor,
        block=block,
        rng=rng,
        remaining=lambda chosen: _eligible(names, list(base.blocks) + chosen),
        screen=lambda score, cands: _screen(score.fits[0].model, splits[0].train, cands),
        extend=lambda structure, e: structure.with_blocks(e),
        start=lambda model, single, k: _merge(model, single, k),
        min_gain=settings.min_rung_gain,
    )
    ladder = run.ladder
    strained |= {e for e, sc in zip(run.chosen[1:], run.scores[1:]) if _at_bound(e, sc.fits)}
    excess_ci = scorer.excess_ci(e0, floor, block, 1 - 2 * settings.alpha, rng)
    structural = {n for n in PASSAGE_BLOCKS if not PASSAGE_BLOCKS[n].param_names}
    unit = UNITS[full.quantity]
    verdict = decide(mse0, floor_sim, excess_ci, ladder, settings, strained, structural, unit=unit)
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
        unit=unit,
    )


def _screen(model: PassageCapstan, train: PassageInputs, remaining: list[str]) -> list[str]:
    """The remaining candidates by how well their signatures correlate with the rung's training residual."""
    if len(remaining) <= 1:
        return remaining
    resid = (model.target(train) - model.reading(train, model.theta_))[:, None]
    resid[train.since_start < float(model.warmup_s)] = np.nan
    corr = signatures(model, model.theta_, remaining, train).effect_correlation(resid)
    return sorted(remaining, key=lambda e: -corr.get(e, 0.0))


def _merge(current: PassageCapstan, single: Score | None, k: int) -> dict:
    """A ladder refit's start: the current rung's fit and the candidate's own fitted block values."""
    theta = dict(current.theta_)
    if single is not None:
        theta.update({lab: v for lab, v in single.fits[k].model.theta_.items() if ":" in lab and lab not in theta})
    return theta
