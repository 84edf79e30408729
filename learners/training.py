"""Two-stage training of PG-CHTC (paper Section IV-B).

Stage 1 pretrains the static backbone ``f_theta`` on single frames (no temporal residual);
stage 2 freezes it and trains ``g_phi`` on sequence chunks.  Both run the shared loop of
:mod:`learners.loop`: AdamW with cosine annealing and early stopping on a validation split
by trajectory, restoring the best weights.  A non-finite loss stops a stage cleanly with
the best weights it had seen, recorded in :attr:`History.stopped` and its epoch log, and a
:class:`~learners.loop.NonFiniteLossWarning`; only one in a stage's first epoch, with no
weights to keep, is an error (:class:`~learners.loop.TrainingError`, also importable from here).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import torch
from torch import Tensor

from learners.cascade import Cascade, CascadeInputs
from learners.loop import LoopSchedule, NonFiniteLossWarning, TrainingError, run_training
from learners.loss import LossWeights, pgchtc_loss
from learners.presets import TrainConfig

__all__ = ["History", "NonFiniteLossWarning", "Sequences", "TrainingError", "fit_feature_norm", "train_two_stage"]


@dataclass
class Sequences:
    """Training data cut into chunks of equal length (padded), all on one device.

    Attributes
    ----------
    inputs : CascadeInputs
        Shapes (C, L, ...): C chunks of L frames.
    log_terminal : Tensor, shape (C, L, n)
        ``ln T[N, N]`` of the ``n`` tendons.
    log_ratio_phys : Tensor, shape (C, L, N-1, n)
    mask : Tensor of bool, shape (C, L)
        Real (not padding) frames.
    """

    inputs: CascadeInputs
    log_terminal: Tensor
    log_ratio_phys: Tensor
    mask: Tensor

    def take(self, idx: Tensor) -> Sequences:
        i = self.inputs
        return Sequences(
            CascadeInputs(i.sin_q[idx], i.alpha[idx], i.log_actuator[idx], i.since_start[idx]),
            self.log_terminal[idx],
            self.log_ratio_phys[idx],
            self.mask[idx],
        )

    def frames(self) -> Sequences:
        """Every real frame as its own length-1 sequence (stage 1 batches frames)."""
        i, m = self.inputs, self.mask
        sel = lambda t: t[m][:, None]  # noqa: E731
        return Sequences(
            CascadeInputs(sel(i.sin_q), sel(i.alpha), sel(i.log_actuator), torch.zeros_like(sel(i.since_start))),
            sel(self.log_terminal),
            sel(self.log_ratio_phys),
            torch.ones_like(m[m][:, None]),
        )

    def __len__(self) -> int:
        return self.mask.shape[0]


@dataclass
class History:
    """Per-epoch losses of both stages.

    ``stopped`` holds a record per stage that a non-finite loss stopped
    (:attr:`learners.loop.TrainHistory.stopped`, with its ``"stage"``); the stage's log ends
    with an entry marked ``"non_finite": True``.
    """

    stage1: list = field(default_factory=list)
    stage2: list = field(default_factory=list)
    best_val1: float = math.inf
    best_val2: float = math.inf
    stopped: list = field(default_factory=list)


def _batch_loss(cascade: Cascade, batch: Sequences, weights: LossWeights, residual: bool) -> tuple[Tensor, dict]:
    n = cascade.n_guides + 1
    sets = torch.tensor([n - 1], device=batch.mask.device)
    log_joint, log_ratio = cascade(batch.inputs, sets, residual=residual)
    return pgchtc_loss(
        log_joint[:, :, 0],
        batch.log_terminal,
        log_ratio[:, :, :, 0],
        batch.log_ratio_phys,
        batch.inputs.alpha,
        weights,
        batch.mask,
    )


def _evaluate(cascade: Cascade, data: Sequences, weights: LossWeights, residual: bool, batch: int) -> float:
    cascade.eval()
    total, frames = 0.0, 0.0
    with torch.no_grad():
        for start in range(0, len(data), batch):
            b = data.take(torch.arange(start, min(start + batch, len(data)), device=data.mask.device))
            loss, _ = _batch_loss(cascade, b, weights, residual)
            n = float(b.mask.sum())
            total += float(loss) * n
            frames += n
    return total / max(frames, 1.0)


def _run_stage(
    cascade: Cascade,
    params,
    train: Sequences,
    val: Sequences,
    weights: LossWeights,
    *,
    residual: bool,
    batch: int,
    schedule: LoopSchedule,
    generator: torch.Generator,
    log: list,
    stopped: list,
    progress=None,
    desc: str = "",
) -> float:
    """One stage through the shared loop; returns its best validation loss."""

    def train_mode() -> None:
        cascade.train()
        if residual:  # stage 2: the frozen backbone's BatchNorm uses its running statistics
            for u in cascade.units:
                u.backbone.eval()

    def batches():
        order = torch.randperm(len(train), generator=generator, device="cpu").to(train.mask.device)
        for start in range(0, len(train), batch):
            b = train.take(order[start : start + batch])
            if b.mask.shape[0] < 2 and not residual:
                continue  # BatchNorm needs two frames
            yield b

    hist = run_training(
        cascade,
        [p for p in params if p.requires_grad],
        schedule,
        batches=batches,
        batch_loss=lambda b: _batch_loss(cascade, b, weights, residual),
        validate=lambda: _evaluate(cascade, val, weights, residual, max(batch, 64)),
        # the mean over every batch of the epoch, the skipped ones included
        batches_per_epoch=math.ceil(len(train) / batch),
        train_mode=train_mode,
        progress=progress,
        desc=desc,
    )
    log.extend(hist.epochs)
    if hist.stopped is not None:
        stopped.append({"stage": desc, **hist.stopped})
    return hist.best_val


def train_two_stage(
    cascade: Cascade,
    train: Sequences,
    val: Sequences,
    cfg: TrainConfig,
    weights: LossWeights,
    *,
    seed: int = 0,
    progress=None,
) -> History:
    """Stage 1 (``f_theta`` on frames), then stage 2 (``g_phi`` on chunks, ``f_theta`` frozen).

    A stage that a non-finite loss stops keeps its best weights; stage 2 still runs after such a
    stage 1, from the kept backbone.
    """
    gen = torch.Generator().manual_seed(seed)
    hist = History()
    backbone = [p for u in cascade.units for p in u.backbone.parameters()]
    stage1 = LoopSchedule(cfg.lr1, cfg.epochs1, cfg.patience1, cfg.weight_decay)
    hist.best_val1 = _run_stage(
        cascade,
        backbone,
        train.frames(),
        val.frames(),
        weights,
        residual=False,
        batch=cfg.batch1,
        schedule=stage1,
        generator=gen,
        log=hist.stage1,
        stopped=hist.stopped,
        progress=progress,
        desc="stage 1 (f_theta)",
    )
    residual_params = [p for u in cascade.units if u.residual is not None for p in u.residual.parameters()]
    if residual_params:
        for p in backbone:
            p.requires_grad_(False)
        try:
            stage2 = LoopSchedule(cfg.lr2, cfg.epochs2, cfg.patience2, cfg.weight_decay)
            hist.best_val2 = _run_stage(
                cascade,
                residual_params,
                train,
                val,
                weights,
                residual=True,
                batch=cfg.batch2,
                schedule=stage2,
                generator=gen,
                log=hist.stage2,
                stopped=hist.stopped,
                progress=progress,
                desc="stage 2 (g_phi)",
            )
        finally:
            for p in backbone:
                p.requires_grad_(True)
    cascade.eval()
    return hist


def fit_feature_norm(cascade: Cascade, sin_q: np.ndarray, alpha: np.ndarray, tensions: np.ndarray) -> None:
    """Channel normalisation of the unit inputs from training data (paper §III-C).

    Parameters
    ----------
    cascade : Cascade or CorrectedCascade
        Its ``feature_mean`` and ``feature_std`` (``5 + n`` channels) are set; ``n`` is its ``n_tendons``.
    sin_q : ndarray, shape (..., 4)
        ``sin`` of the adjacent joint angles of each guide.
    alpha : ndarray
        Wraps [rad].
    tensions : ndarray, shape (..., n)
        Tensions [N] the units read, one column per tendon.
    """
    sq = sin_q.reshape(-1, 4)
    ca = np.cos(alpha).reshape(-1, 1)
    t = tensions.reshape(-1, cascade.n_tendons)
    mean = np.r_[sq.mean(0), ca.mean(0), t.mean(0)]
    std = np.r_[sq.std(0), ca.std(0), t.std(0)]
    std = np.where(std > 1e-8, std, 1.0)
    cascade.feature_mean.copy_(torch.as_tensor(mean, dtype=cascade.feature_mean.dtype))
    cascade.feature_std.copy_(torch.as_tensor(std, dtype=cascade.feature_std.dtype))
