"""The bench passage's part of the diagnosis: its splits, refit, strata and signatures (:doc:`/guide/diagnosis`).

* **Splits by file.** A held-out set of files, or blocked cross-validation over files: a
  file is never split, since a bench's samples are correlated over seconds.
* **Refits** by :func:`~tendon_id.zoo.passage.fitting.calibrate_passage`, the base on each
  split from its fit on all the training files, each candidate from that split's base fit.
* **Candidates** are the passage blocks (:data:`~tendon_id.zoo.passage.blocks.PASSAGE_BLOCKS`);
  one that reads a signal the data lack is skipped (the generic diagnosis asks
  :meth:`~tendon_id.family.blocks.EffectBlock.missing`).
* **Where**: near reversals, by load, by speed, by position, since a log's start.
* **Signatures**: a block's change of the prediction at its probe values, the residual's
  first-order shape where that block is missing.
* **The noise floor** comes from the residual's first differences (a bench declares no
  sensor noise).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from friction_models import play_operator
from tendon_id.diagnosis.library import Library
from tendon_id.diagnosis.splits import Split
from tendon_id.diagnosis.where import quartile_masks
from tendon_id.errors import ConfigError
from tendon_id.family.fit import Fit
from tendon_id.family.inputs import by_slices
from tendon_id.zoo.passage.fitting import calibrate_passage, calibration_record, data_scales
from tendon_id.zoo.passage.inputs import PassageInputs

__all__ = ["REVERSAL_SHARE", "UNITS", "file_splits", "holding", "passage_refit", "passage_strata", "signatures"]

#: Share of the travel's range the input must move back after a reversal to leave the
#: "near reversals" stratum [-].
REVERSAL_SHARE = 0.05
#: The SI unit of each quantity, as reports write it.
UNITS = {"torque": "N m", "tension": "N"}


def file_splits(train: list, test: list | None, folds: int) -> tuple[list[Split], str]:
    """Held-out files, or blocked cross-validation over the training files (never within a file)."""
    if test is not None:
        return [Split(PassageInputs.from_recordings(train), PassageInputs.from_recordings(test))], (
            f"held-out files ({len(train)} for fitting, {len(test)} held out)"
        )
    if len(train) < 2:
        raise ConfigError("cross-validation by file needs two or more files; give held-out files", param="test")
    k = min(folds, len(train))
    groups = np.array_split(np.arange(len(train)), k)
    # The files' signals are stacked once; each fold's held-out files are a part of them (views),
    # and so is its training set where the held-out files are at an end (a copy only in between).
    whole = PassageInputs.from_recordings(train)
    edges = np.cumsum([0] + [r.n_frames for r in train])
    splits = []
    for g in groups:
        splits.append(Split(*whole.held_out(int(edges[g[0]]), int(edges[g[-1] + 1]))))
    return splits, f"{k}-fold cross-validation by file ({len(train)} files)"


def passage_refit(structure, train: PassageInputs, start: dict, max_nfev: int) -> Fit:
    """Refit ``structure`` on ``train`` from ``start`` (``{label: value}``); ``Fit.model`` is the fitted copy."""
    model = type(structure)(**{**structure.get_params(), "maxeval": max(int(max_nfev), structure.maxeval)})
    fit = calibrate_passage(model, train, start=start)
    model.theta_, model.quantity_, model.calibration_ = fit.values, train.quantity, calibration_record(fit)
    fit.model = model
    return fit


def residual(model, inputs: PassageInputs) -> NDArray:
    """Measured minus predicted side [Q], shape (T, 1), NaN in the model's warm-up."""
    e = model.target(inputs) - model.reading(inputs, model.theta_)
    e[inputs.since_start < float(model.warmup_s)] = np.nan
    return e[:, None]


def passage_strata(inputs: PassageInputs):
    """Yield ``(name, kind, mask)`` of a bench's strata: near reversals, load, speed, position, time since start.

    Made one kind at a time as they are read, so that a bool per frame is held for one kind's
    masks, not all eighteen (and their variables) at once: 3.6·10^6 frames each at an hour.
    """
    x = inputs.travel()
    band = REVERSAL_SHARE * float(np.ptp(x))
    stuck = holding(x, band, inputs.reset) if band > 0 else np.zeros(x.shape, bool)
    yield "near reversals", "reversal", stuck
    yield "away from reversals", "reversal", ~stuck
    del stuck
    unit = UNITS[inputs.quantity]
    yield from ((n, "load", m) for n, m in quartile_masks(np.abs(inputs.output), "output load", unit))
    speed = inputs.speed_magnitude()  # read here alone: not kept beside the strata
    rest = "input at rest" if speed.min() == 0 else None
    yield from ((n, "speed", m) for n, m in quartile_masks(speed, "input speed", "rad/s", least=rest))
    del speed
    if inputs.position is not None:
        angle = inputs.position_out if inputs.position_out is not None else inputs.position
        yield from ((n, "position", m) for n, m in quartile_masks(angle, "position", "rad"))
    yield from ((n, "start", m) for n, m in quartile_masks(inputs.since_start, "time since log start", "s"))


def holding(x: NDArray, band: float, reset: NDArray) -> NDArray[np.bool_]:
    """Frames where a play operator of half-width ``band`` [x's unit] on ``x`` holds (slip state 0).

    Slice by slice with the operator's output carried (:func:`~tendon_id.family.inputs.by_slices`):
    the bits of the whole scan, without its three whole-length arrays.
    """
    last = None

    def fill(a, b):
        nonlocal last
        played = play_operator(x[a:b], band, reset[a:b], y0=last)
        last = played.log_out[-1]
        return played.sigma == 0

    return by_slices(len(x), np.bool_, fill)


def signatures(fitted, inputs: PassageInputs, blocks: dict) -> Library:
    """Each block's change of ``fitted``'s prediction when added at its probe values, shape (T, 1, C).

    Window by window (:meth:`~tendon_id.zoo.passage.model.PassageCapstan.reading_windows`, the
    whole reading's bits): the base's reading is made again per column, a window at a time, rather
    than kept whole beside the columns.
    """
    scale = data_scales(inputs)
    theta = fitted.theta_
    labels = list(blocks)
    columns = np.empty((inputs.n_frames, 1, len(labels)))  # filled column by column: no list to stack
    for k, (e, block) in enumerate(blocks.items()):
        probe = {f"{e}:{p}": v for p, v in block.probe(scale).items()}
        model, at = fitted.with_blocks(block), {**theta, **probe}
        if not (model.streams and fitted.streams):  # one of them reads later frames: whole readings
            columns[:, 0, k] = model.reading(inputs, at)
            columns[:, 0, k] -= fitted.reading(inputs, theta)
            continue
        for (a, b, y), (_, _, y0) in zip(model.reading_windows(inputs, at), fitted.reading_windows(inputs, theta)):
            np.subtract(y, y0, out=columns[a:b, 0, k])
    return Library(labels, list(labels), columns)
