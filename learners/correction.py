"""PG-CHTC-NS: the ratio cascade with the nonsmooth capstan as its prior and the hysteresis state as its memory.

Through guide ``k`` the cascade multiplies the tension by a ratio (paper Eq. (8)'s cascade),

    ln r_k = ln r_prior,k + delta_k,        |delta_k| < bound,

where ``r_prior`` is the calibrated nonsmooth capstan's ratio at that guide (contact gate and
play operator, its state carried along the chain and through time by the caller) and
``delta`` is a bounded correction learned from the paper's unit inputs (Eq. (7)) plus the
prior's state at the guide (:mod:`friction_models.play_state`).  The correction starts at
zero, so an untrained cascade is the calibrated physics.  Its memory is the play
operator's state, not a window of frames: a frame needs no history beyond that state, so
training runs on single frames and streaming costs O(1) per frame.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import torch
from torch import Tensor, nn

from friction_models.play_state import N_STATE
from learners.cascade import LOG_RATIO_BOUND, normalised_geometry, normalised_tensions
from learners.loop import LoopSchedule, TrainHistory, run_training
from learners.loss import LossWeights, pgchtc_loss
from learners.unit import N_GEOMETRY, n_features


@dataclass(frozen=True)
class CorrectionConfig:
    """Architecture of the correction unit.

    Parameters
    ----------
    hidden : tuple of int
        Widths of the GELU MLP's hidden layers.
    bound : float
        Largest correction of one guide's log ratio, ``|delta_k| < bound`` [-].
    state_inputs : bool
        Feed the prior's hysteresis state (False: the "w/o state inputs" ablation).
    """

    hidden: tuple[int, ...] = (64, 64, 32)
    bound: float = 0.5
    state_inputs: bool = True

    def __post_init__(self) -> None:
        if not self.bound > 0:
            raise ValueError("the correction's bound must be positive")

    def inputs_for(self, n_tendons: int) -> int:
        """Inputs of the unit for ``n`` tendons per set: the paper's ``5 + n`` (Eq. (7)), plus the state of the
        guide's ``n`` tendons (8 + 12 for the paper's 3)."""
        return n_features(n_tendons) + (int(n_tendons) * N_STATE if self.state_inputs else 0)


class CorrectionUnit(nn.Module):
    """``delta = bound * tanh(f(x))``: a GELU MLP with a zero head, so that it starts at no correction.

    ``n_tendons`` (``n``) sets its width: ``n_inputs`` (:meth:`CorrectionConfig.inputs_for`) in, one correction
    per tendon out.
    """

    def __init__(self, cfg: CorrectionConfig, n_tendons: int = 3):
        super().__init__()
        self.cfg = cfg
        self.n_tendons = int(n_tendons)
        self.n_inputs = cfg.inputs_for(self.n_tendons)
        layers: list[nn.Module] = []
        width = self.n_inputs
        for h in cfg.hidden:
            layers += [nn.Linear(width, h), nn.GELU()]
            width = h
        self.body = nn.Sequential(*layers)
        self.head = nn.Linear(width, self.n_tendons)
        nn.init.zeros_(self.head.weight)
        nn.init.zeros_(self.head.bias)

    def forward(self, x: Tensor) -> Tensor:
        return self.cfg.bound * torch.tanh(self.head(self.body(x)))


@dataclass
class CorrectionInputs:
    """One frame per row: what the corrected cascade reads.

    Attributes
    ----------
    sin_q : Tensor, shape (F, K, 4)
        ``sin`` of the adjacent joint angles of each guide (paper Eq. (2)).
    alpha : Tensor, shape (F, K)
        Backbone wrap [rad] (paper Eq. (3)).
    log_actuator : Tensor of float64, shape (F, S, n)
        ``ln T[1, j, i]`` of the sets to propagate, ``n`` tendons per set.
    prior_log_ratio : Tensor of float64, shape (F, K, S, n)
        The prior's ``ln r`` at every guide (0 where a set does not pass it).
    state : Tensor, shape (F, K, S, n, 4)
        The prior's play-operator state at every guide.
    """

    sin_q: Tensor
    alpha: Tensor
    log_actuator: Tensor
    prior_log_ratio: Tensor
    state: Tensor

    def take(self, idx: Tensor) -> CorrectionInputs:
        return CorrectionInputs(*(t[idx] for t in self.tensors()))

    def tensors(self) -> tuple[Tensor, ...]:
        return self.sin_q, self.alpha, self.log_actuator, self.prior_log_ratio, self.state

    def __len__(self) -> int:
        return self.alpha.shape[0]


class CorrectedCascade(nn.Module):
    """The nonsmooth prior's ratio cascade with one (``tied``) or per-guide correction units.

    Parameters
    ----------
    n_guides : int
        ``N - 1``.
    cfg : CorrectionConfig
    tied : bool
        One unit for every guide, or one per guide.
    n_tendons : int
        Tendons per set ``n`` (the paper's 3).
    """

    def __init__(self, n_guides: int, cfg: CorrectionConfig, tied: bool = True, n_tendons: int = 3):
        super().__init__()
        self.n_guides = n_guides
        self.cfg = cfg
        self.tied = tied
        self.n_tendons = int(n_tendons)
        self.units = nn.ModuleList(CorrectionUnit(cfg, self.n_tendons) for _ in range(1 if tied else n_guides))
        self.register_buffer("feature_mean", torch.zeros(n_features(self.n_tendons)))
        self.register_buffer("feature_std", torch.ones(n_features(self.n_tendons)))

    def unit(self, g: int) -> CorrectionUnit:
        return self.units[0 if self.tied else g]

    def unit_input(self, geo: Tensor, log_t: Tensor, state: Tensor) -> Tensor:
        """The unit's input at one guide: geometry (..., 5), ``ln T`` entering it (..., S, n), state (..., S, n, 4)."""
        parts = [
            geo[..., None, :].expand(*log_t.shape[:-1], N_GEOMETRY),
            normalised_tensions(log_t, self.feature_mean, self.feature_std),
        ]
        if self.cfg.state_inputs:
            parts.append(state.reshape(*state.shape[:-2], self.n_tendons * N_STATE).to(self.feature_mean.dtype))
        return torch.cat(parts, dim=-1)

    def forward(self, inp: CorrectionInputs, sets: Tensor) -> tuple[Tensor, Tensor]:
        """Propagate every set through the guides.

        Parameters
        ----------
        inp : CorrectionInputs
        sets : Tensor of int, shape (S,)
            0-based set indices of ``inp.log_actuator``'s second axis.

        Returns
        -------
        log_joint : Tensor of float64, shape (F, S, n)
            ``ln T_hat[j, j, i]``.
        log_ratio : Tensor of float64, shape (F, K, S, n)
            ``ln r`` per guide (0 where a set does not pass it).
        """
        log_t = inp.log_actuator.to(torch.float64)
        log_ratio = torch.zeros(inp.prior_log_ratio.shape, dtype=torch.float64, device=log_t.device)
        geo = normalised_geometry(inp.sin_q, inp.alpha, self.feature_mean, self.feature_std)  # (F, K, 5)
        for g in range(self.n_guides):
            active = sets > g
            if not bool(active.any()):
                break
            x_t = log_t[:, active]
            delta = self.unit(g)(self.unit_input(geo[:, g], x_t, inp.state[:, g, active]))
            lr = (inp.prior_log_ratio[:, g, active] + delta.to(torch.float64)).clamp(-LOG_RATIO_BOUND, LOG_RATIO_BOUND)
            log_t = log_t.clone()
            log_t[:, active] = x_t + lr
            log_ratio[:, g, active] = lr
        return log_t, log_ratio


def _loss(cascade: CorrectedCascade, batch: tuple, weights: LossWeights) -> tuple[Tensor, dict]:
    inp, log_terminal = batch
    sets = torch.tensor([cascade.n_guides], device=log_terminal.device)  # the terminal set passes every guide
    log_joint, log_ratio = cascade(inp, sets)
    return pgchtc_loss(
        log_joint[:, 0],
        log_terminal.to(torch.float64),
        log_ratio[:, :, 0],
        inp.prior_log_ratio[:, :, 0],
        inp.alpha.to(torch.float64),
        weights,
    )


def _evaluate(cascade: CorrectedCascade, data: tuple, weights: LossWeights, batch: int) -> float:
    cascade.eval()
    inp, term = data
    total = 0.0
    with torch.no_grad():
        for start in range(0, len(inp), batch):
            idx = torch.arange(start, min(start + batch, len(inp)), device=term.device)
            loss, _ = _loss(cascade, (inp.take(idx), term[idx]), weights)
            total += float(loss) * len(idx)
    return total / max(len(inp), 1)


def train_correction(
    cascade: CorrectedCascade,
    train: tuple[CorrectionInputs, Tensor],
    val: tuple[CorrectionInputs, Tensor],
    schedule: LoopSchedule,
    weights: LossWeights,
    *,
    batch: int = 256,
    seed: int = 0,
    progress=None,
) -> TrainHistory:
    """Train the correction units on frames of the terminal set with the paper's loss (Eqs. (11)–(15)).

    The prior term is measured against the nonsmooth prior, so it is ``lambda sum_k delta_k^2``.
    ``train`` and ``val`` are ``(inputs of the terminal set only, ln T[N, N] labels (F, n))``.
    Early stopping keeps the best epoch, and the untrained cascade (the prior itself) counts as
    epoch 0: a correction that does not lower the validation loss is not kept.
    """
    gen = torch.Generator().manual_seed(seed)
    inp, term = train
    untrained = copy.deepcopy(cascade.state_dict())
    val0 = _evaluate(cascade, val, weights, max(batch, 1024))

    def batches():
        order = torch.randperm(len(inp), generator=gen, device="cpu").to(term.device)
        for start in range(0, len(inp), batch):
            idx = order[start : start + batch]
            yield inp.take(idx), term[idx]

    params = [p for p in cascade.parameters() if p.requires_grad]
    hist = run_training(
        cascade,
        params,
        schedule,
        batches=batches,
        batch_loss=lambda b: _loss(cascade, b, weights),
        validate=lambda: _evaluate(cascade, val, weights, max(batch, 1024)),
        batches_per_epoch=math.ceil(len(inp) / batch),
        progress=progress,
        desc="correction",
    )
    if not hist.best_val < val0:
        cascade.load_state_dict(untrained)
        hist.best_val, hist.best_epoch = val0, 0
    cascade.eval()
    return hist
