"""The one training loop of the learners: AdamW, cosine annealing, clipping, early stopping.

PG-CHTC's two stages (:mod:`learners.training`) and the learning-only baselines
(:mod:`learners.baselines`) both train through :func:`run_training`.  They differ only in
what a batch is, how its loss is computed and how the epoch's training loss is averaged,
which they hand in; everything that decides the weights (the optimiser, the learning-rate
schedule, the gradient clipping, when to stop and which weights to keep) lives here once.
"""

from __future__ import annotations

import copy
import math
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import torch
from torch import Tensor, nn


class TrainingError(RuntimeError):
    """Training could not continue: the loss became NaN or infinite before any epoch finished."""


class NonFiniteLossWarning(RuntimeWarning):
    """Training stopped early on a NaN or infinite loss and kept the best weights it had seen."""


@dataclass(frozen=True)
class LoopSchedule:
    """What the loop needs of a schedule.

    Parameters
    ----------
    lr : float
        Peak learning rate of AdamW, annealed to zero by a cosine over ``epochs``.
    epochs : int
        Most epochs to run.
    patience : int
        Epochs without a better validation loss after which training stops.
    weight_decay : float
        AdamW's decoupled weight decay.
    clip_norm : float
        Largest global gradient norm; larger gradients are scaled down to it.
    """

    lr: float
    epochs: int
    patience: int
    weight_decay: float
    clip_norm: float = 10.0


@dataclass
class TrainHistory:
    """Per-epoch mean training and validation losses (log domain, Eq. (12)).

    Attributes
    ----------
    epochs : list of dict
        ``{"epoch", "train", "val"}`` per epoch run; ``val`` is NaN without validation.
        After a non-finite loss, a last entry for the broken epoch has ``"non_finite": True``.
    best_val : float
        Lowest validation loss (``inf`` without validation or epochs).
    best_epoch : int
        The epoch (from 1) whose weights were kept: the best one, or the last one without
        validation.
    stopped : dict or None
        ``{"epoch", "what", "value", "kept_epoch"}`` when a non-finite training (``what`` is
        ``"loss"``) or validation loss (``"validation loss"``) stopped training; else None.
    """

    epochs: list = field(default_factory=list)
    best_val: float = math.inf
    best_epoch: int = 0
    stopped: dict | None = None


def run_training(
    module: nn.Module,
    params: Sequence[nn.Parameter],
    schedule: LoopSchedule,
    *,
    batches: Callable[[], Iterable[Any]],
    batch_loss: Callable[[Any], tuple[Tensor, dict | None]],
    validate: Callable[[], float] | None,
    batches_per_epoch: int | None = None,
    train_mode: Callable[[], None] | None = None,
    progress: Callable | None = None,
    desc: str = "",
) -> TrainHistory:
    """Train ``params`` of ``module`` epoch by epoch, with early stopping when validated.

    Each epoch puts the module in training mode, steps AdamW once per batch of
    ``batches()`` (gradients clipped to ``schedule.clip_norm``), steps the cosine schedule,
    then validates.  A validation loss lower than the best by more than 1e-12 keeps a copy
    of the weights; ``schedule.patience`` epochs in a row without one stop training.

    A NaN or infinite batch loss (or validation loss) stops training cleanly: the weights of
    the best finished epoch (the last one without validation) are restored, the stop is
    recorded in ``TrainHistory.stopped`` and as a last entry of ``epochs``, and a
    :class:`NonFiniteLossWarning` says so.  Only when no epoch has finished is there nothing
    to keep, and it raises.

    Parameters
    ----------
    module : nn.Module
        Whose state is saved and restored (all of it, frozen parts and buffers included).
    params : sequence of nn.Parameter
        What the optimiser updates and the clipping measures.
    schedule : LoopSchedule
    batches : callable
        ``batches()`` is called once per epoch, after the module is put in training mode,
        and iterates over that epoch's batches in order.  Batches that cannot be trained
        on (a single frame through BatchNorm) are the caller's to leave out.
    batch_loss : callable
        ``batch_loss(batch)`` is ``(loss, parts)``: the scalar loss to minimise and, for
        the error message, its terms (a dict) or None.
    validate : callable or None
        ``validate()`` is the validation loss after an epoch (it may leave the module in
        eval mode).  Without it every epoch runs and the last weights are kept.
    batches_per_epoch : int, optional
        Divide an epoch's summed batch losses by this (at least 1) to report its training
        loss, leaving-out batches included; by default by the number of batches stepped.
    train_mode : callable, optional
        Puts the module in training mode at the start of each epoch (default
        ``module.train()``); e.g. to keep a frozen part's BatchNorm on its running statistics.
    progress : callable, optional
        ``progress(iterable, desc)`` wraps the epoch loop (e.g. a tqdm bar).
    desc : str
        Names the training in the progress bar and in errors.

    Returns
    -------
    TrainHistory
        The kept weights are loaded in ``module``, which is left in eval mode.

    Raises
    ------
    TrainingError
        When the loss stops being finite before any epoch has finished.

    Warns
    -----
    NonFiniteLossWarning
        When it stops being finite later: training stopped and kept the best weights.
    """
    opt = torch.optim.AdamW(params, lr=schedule.lr, weight_decay=schedule.weight_decay)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=max(schedule.epochs, 1))
    hist = TrainHistory()
    best_state, bad = None, 0  # None: no finished epoch to fall back on yet
    epochs = progress(range(schedule.epochs), desc) if progress else range(schedule.epochs)
    for epoch in epochs:
        if train_mode is None:
            module.train()
        else:
            train_mode()
        running, steps, broken = 0.0, 0, None
        for b in batches():
            loss, parts = batch_loss(b)
            if not torch.isfinite(loss):
                broken = ("loss", float(loss.detach()), parts)
                break
            opt.zero_grad(set_to_none=True)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(params, schedule.clip_norm)
            opt.step()
            running += float(loss.detach())
            steps += 1
        if broken is None:
            sched.step()
            val_loss = validate() if validate is not None else math.nan
            if validate is not None and not math.isfinite(val_loss):
                broken = ("validation loss", val_loss, None)
        if broken is not None:
            _stop(hist, desc, epoch, broken, best_state is not None)
            break
        divisor = steps if batches_per_epoch is None else batches_per_epoch
        hist.epochs.append({"epoch": epoch + 1, "train": running / max(divisor, 1), "val": val_loss})
        if validate is None:  # the last finished epoch is the one kept
            hist.best_epoch = epoch + 1
            best_state = copy.deepcopy(module.state_dict())
            continue
        if val_loss < hist.best_val - 1e-12:
            hist.best_val, hist.best_epoch, bad = val_loss, epoch + 1, 0
            best_state = copy.deepcopy(module.state_dict())
        else:
            bad += 1
            if bad >= schedule.patience:
                break
    if best_state is not None and (validate is not None or hist.stopped is not None):
        module.load_state_dict(best_state)
    module.eval()
    return hist


def _stop(hist: TrainHistory, desc: str, epoch: int, broken: tuple, kept: bool) -> None:
    """Record a non-finite loss and warn, or raise when no finished epoch's weights are left to keep."""
    what, value, parts = broken
    if not kept:
        raise TrainingError(_non_finite_message(desc, value, epoch, parts, what))
    message = (
        f"{desc + ': ' if desc else ''}the {what} became {value} at epoch {epoch + 1}; training stopped there "
        f"and kept the weights of epoch {hist.best_epoch}"
    )
    hist.stopped = {"epoch": epoch + 1, "what": what, "value": value, "kept_epoch": hist.best_epoch}
    # one entry for the broken epoch, so that the history a zoo model saves records the stop too
    hist.epochs.append(
        {"epoch": epoch + 1, "train": value if what == "loss" else math.nan, "val": math.nan, "non_finite": True}
    )
    warnings.warn(message, NonFiniteLossWarning, stacklevel=3)


def _non_finite_message(desc: str, value: float, epoch: int, parts: dict | None, what: str = "loss") -> str:
    where = f"{desc}: the {what} became {value} at epoch {epoch + 1}"
    if parts is not None:
        where += f" (parts {parts})"
    return where + "; lower the learning rate or check the data for non-positive tensions"
