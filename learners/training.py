"""Two-stage training of PG-CHTC (paper Section IV-B).

Stage 1 pretrains the static backbone ``f_theta`` on single frames (no temporal residual);
stage 2 freezes it and trains ``g_phi`` on sequence chunks.  Both use AdamW with cosine
annealing and early stopping on a validation split by trajectory, restoring the best
weights.  A non-finite loss stops training with a clear error.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np
import torch
from torch import Tensor

from learners.cascade import Cascade, CascadeInputs
from learners.loss import LossWeights, pgchtc_loss
from learners.presets import TrainConfig


class TrainingError(RuntimeError):
    """Training could not continue (for example the loss became NaN or infinite)."""


@dataclass
class Sequences:
    """Training data cut into chunks of equal length (padded), all on one device.

    Attributes
    ----------
    inputs : CascadeInputs
        Shapes (C, L, ...): C chunks of L frames.
    log_terminal : Tensor, shape (C, L, 3)
    log_ratio_phys : Tensor, shape (C, L, N-1, 3)
    mask : Tensor of bool, shape (C, L)
        Real (not padding) frames.
    """

    inputs: CascadeInputs
    log_terminal: Tensor
    log_ratio_phys: Tensor
    mask: Tensor

    def take(self, idx: Tensor) -> Sequences:
        i = self.inputs
        return Sequences(CascadeInputs(i.sin_q[idx], i.alpha[idx], i.log_actuator[idx], i.since_start[idx]),
                         self.log_terminal[idx], self.log_ratio_phys[idx], self.mask[idx])

    def frames(self) -> Sequences:
        """Every real frame as its own length-1 sequence (stage 1 batches frames)."""
        i, m = self.inputs, self.mask
        sel = lambda t: t[m][:, None]  # noqa: E731
        return Sequences(CascadeInputs(sel(i.sin_q), sel(i.alpha), sel(i.log_actuator), torch.zeros_like(sel(i.since_start))),
                         sel(self.log_terminal), sel(self.log_ratio_phys), torch.ones_like(m[m][:, None]))

    def __len__(self) -> int:
        return self.mask.shape[0]


@dataclass
class History:
    """Per-epoch losses of both stages."""

    stage1: list = field(default_factory=list)
    stage2: list = field(default_factory=list)
    best_val1: float = math.inf
    best_val2: float = math.inf


def _batch_loss(cascade: Cascade, batch: Sequences, weights: LossWeights, residual: bool) -> tuple[Tensor, dict]:
    n = cascade.n_guides + 1
    sets = torch.tensor([n - 1], device=batch.mask.device)
    log_joint, log_ratio = cascade(batch.inputs, sets, residual=residual)
    return pgchtc_loss(log_joint[:, :, 0], batch.log_terminal, log_ratio[:, :, :, 0], batch.log_ratio_phys, batch.inputs.alpha, weights, batch.mask)


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


def _run_stage(cascade: Cascade, params, train: Sequences, val: Sequences, weights: LossWeights, *, residual: bool, lr: float,
               batch: int, epochs: int, patience: int, weight_decay: float, generator: torch.Generator, log: list,
               progress=None, desc: str = "") -> float:
    params = [p for p in params if p.requires_grad]
    opt = torch.optim.AdamW(params, lr=lr, weight_decay=weight_decay)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=max(epochs, 1))
    best, best_state, bad = math.inf, copy.deepcopy(cascade.state_dict()), 0
    epoch_iter = progress(range(epochs), desc) if progress else range(epochs)
    for epoch in epoch_iter:
        cascade.train()
        if not residual:
            pass
        else:  # stage 2: the frozen backbone's BatchNorm uses its running statistics
            for u in cascade.units:
                u.backbone.eval()
        order = torch.randperm(len(train), generator=generator, device="cpu").to(train.mask.device)
        running = 0.0
        for start in range(0, len(train), batch):
            b = train.take(order[start : start + batch])
            if b.mask.shape[0] < 2 and not residual:
                continue  # BatchNorm needs two frames
            loss, parts = _batch_loss(cascade, b, weights, residual)
            if not torch.isfinite(loss):
                raise TrainingError(f"{desc}: the loss became {float(loss.detach())} at epoch {epoch + 1} (parts {parts}); "
                                    "lower the learning rate or check the data for non-positive tensions")
            opt.zero_grad(set_to_none=True)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(params, 10.0)
            opt.step()
            running += float(loss.detach())
        sched.step()
        val_loss = _evaluate(cascade, val, weights, residual, max(batch, 64))
        log.append({"epoch": epoch + 1, "train": running / max(1, math.ceil(len(train) / batch)), "val": val_loss})
        if val_loss < best - 1e-12:
            best, best_state, bad = val_loss, copy.deepcopy(cascade.state_dict()), 0
        else:
            bad += 1
            if bad >= patience:
                break
    cascade.load_state_dict(best_state)  # best weights restored
    return best


def train_two_stage(cascade: Cascade, train: Sequences, val: Sequences, cfg: TrainConfig, weights: LossWeights, *,
                    seed: int = 0, progress=None) -> History:
    """Stage 1 (``f_theta`` on frames), then stage 2 (``g_phi`` on chunks, ``f_theta`` frozen)."""
    gen = torch.Generator().manual_seed(seed)
    hist = History()
    backbone = [p for u in cascade.units for p in u.backbone.parameters()]
    hist.best_val1 = _run_stage(cascade, backbone, train.frames(), val.frames(), weights, residual=False, lr=cfg.lr1,
                                batch=cfg.batch1, epochs=cfg.epochs1, patience=cfg.patience1, weight_decay=cfg.weight_decay,
                                generator=gen, log=hist.stage1, progress=progress, desc="stage 1 (f_theta)")
    residual_params = [p for u in cascade.units if u.residual is not None for p in u.residual.parameters()]
    if residual_params:
        for p in backbone:
            p.requires_grad_(False)
        try:
            hist.best_val2 = _run_stage(cascade, residual_params, train, val, weights, residual=True, lr=cfg.lr2,
                                        batch=cfg.batch2, epochs=cfg.epochs2, patience=cfg.patience2,
                                        weight_decay=cfg.weight_decay, generator=gen, log=hist.stage2, progress=progress,
                                        desc="stage 2 (g_phi)")
        finally:
            for p in backbone:
                p.requires_grad_(True)
    cascade.eval()
    return hist


def fit_feature_norm(cascade: Cascade, sin_q: np.ndarray, alpha: np.ndarray, tensions: np.ndarray) -> None:
    """Channel normalisation of the unit inputs from training data (paper §III-C)."""
    sq = sin_q.reshape(-1, 4)
    ca = np.cos(alpha).reshape(-1, 1)
    t = tensions.reshape(-1, 3)
    mean = np.r_[sq.mean(0), ca.mean(0), t.mean(0)]
    std = np.r_[sq.std(0), ca.std(0), t.std(0)]
    std = np.where(std > 1e-8, std, 1.0)
    cascade.feature_mean.copy_(torch.as_tensor(mean, dtype=cascade.feature_mean.dtype))
    cascade.feature_std.copy_(torch.as_tensor(std, dtype=cascade.feature_std.dtype))
