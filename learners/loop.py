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
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import torch
from torch import Tensor, nn


class TrainingError(RuntimeError):
    """Training could not continue (for example the loss became NaN or infinite)."""


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
    best_val : float
        Lowest validation loss (``inf`` without validation or epochs).
    best_epoch : int
        The epoch (from 1) whose weights were kept: the best one, or the last one without
        validation.
    """

    epochs: list = field(default_factory=list)
    best_val: float = math.inf
    best_epoch: int = 0


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
        When a batch loss stops being finite.
    """
    opt = torch.optim.AdamW(params, lr=schedule.lr, weight_decay=schedule.weight_decay)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=max(schedule.epochs, 1))
    hist = TrainHistory()
    best_state, bad = copy.deepcopy(module.state_dict()), 0
    epochs = progress(range(schedule.epochs), desc) if progress else range(schedule.epochs)
    for epoch in epochs:
        if train_mode is None:
            module.train()
        else:
            train_mode()
        running, steps = 0.0, 0
        for b in batches():
            loss, parts = batch_loss(b)
            if not torch.isfinite(loss):
                raise TrainingError(_non_finite_message(desc, float(loss.detach()), epoch, parts))
            opt.zero_grad(set_to_none=True)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(params, schedule.clip_norm)
            opt.step()
            running += float(loss.detach())
            steps += 1
        sched.step()
        val_loss = validate() if validate is not None else math.nan
        divisor = steps if batches_per_epoch is None else batches_per_epoch
        hist.epochs.append({"epoch": epoch + 1, "train": running / max(divisor, 1), "val": val_loss})
        if validate is None:
            continue
        if val_loss < hist.best_val - 1e-12:
            hist.best_val, hist.best_epoch, bad = val_loss, epoch + 1, 0
            best_state = copy.deepcopy(module.state_dict())
        else:
            bad += 1
            if bad >= schedule.patience:
                break
    if validate is not None:
        module.load_state_dict(best_state)
    else:
        hist.best_epoch = len(hist.epochs)
    module.eval()
    return hist


def _non_finite_message(desc: str, value: float, epoch: int, parts: dict | None) -> str:
    where = f"{desc}: the loss became {value} at epoch {epoch + 1}"
    if parts is not None:
        where += f" (parts {parts})"
    return where + "; lower the learning rate or check the data for non-positive tensions"
