"""Networks, sizes and schedules of the learning-only baselines (MLP [15], LSTM [16], Transformer [13]).

What the baselines are and why they are sized as they are is told in :mod:`learners.baselines`,
which trains them and re-exports everything here.  This module only builds them: the
configuration (:class:`BaselineConfig`), the named presets with their optimisation
schedules (:data:`PRESETS`, :func:`baseline_config`) and the torch modules
(:class:`BaselineNet`).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import Tensor, nn

from learners.presets import PRESETS as UNIT_PRESETS
from learners.unit import SlidingWindowLayer, gelu_mlp_body

KINDS = ("mlp", "lstm", "transformer")


@dataclass(frozen=True)
class BaselineConfig:
    """Architecture of a baseline.

    Parameters
    ----------
    kind : {"mlp", "lstm", "transformer"}
    n_inputs : int
        Channels per frame (``5 + n`` for the unit-level form, ``(n + 2) N`` end to end: 8 and 5N for
        the paper's three tendons).
    hidden : tuple of int
        MLP hidden widths (paper preset: 512/512/256, as ``f_theta``).
    lstm_hidden, lstm_layers : int
        LSTM state size and depth (paper preset: 180 x 2, about 400 k parameters).
    d_model, n_heads, n_layers, d_ff : int
        Transformer sizes (paper preset: 128, 4, 3, 256, as ``g_phi``: about 400 k).
    window : int
        Frames each Transformer layer attends to (the current one and ``window - 1`` before).
    n_tendons : int
        Tendons per set ``n``: the width of the output, one log ratio per tendon (the paper's 3).
    """

    kind: str
    n_inputs: int
    hidden: tuple[int, ...] = (512, 512, 256)
    lstm_hidden: int = 180
    lstm_layers: int = 2
    d_model: int = 128
    n_heads: int = 4
    n_layers: int = 3
    d_ff: int = 256
    window: int = 20
    n_tendons: int = 3

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"unknown baseline {self.kind!r}; known: {', '.join(KINDS)}")
        if self.n_inputs < 1 or self.window < 1 or self.d_model % self.n_heads:
            raise ValueError("n_inputs and window must be >= 1 and d_model divisible by n_heads")
        if self.n_tendons < 1:
            raise ValueError("n_tendons must be >= 1")

    @property
    def sequential(self) -> bool:
        """Whether the model reads a history (trained on chunks) rather than single frames."""
        return self.kind != "mlp"


@dataclass(frozen=True)
class Schedule:
    """Optimisation schedule: AdamW + cosine annealing + early stopping (:mod:`learners.loop`).

    ``batch`` counts frames for the static MLP and chunks of ``chunk`` frames for the
    sequence models.
    """

    lr: float
    batch: int
    epochs: int
    patience: int
    chunk: int = 256
    weight_decay: float = 1e-4


@dataclass(frozen=True)
class BaselinePreset:
    """A named size: :class:`BaselineConfig` fields (``arch``) and the schedule of each kind of model."""

    arch: dict
    static: Schedule
    sequence: Schedule


def _paper() -> BaselinePreset:
    # The paper gives no schedule for its baselines; for a matched comparison the MLP gets
    # f_theta's (stage 1) and the sequence models g_phi's (stage 2), paper Section IV-B.
    t = UNIT_PRESETS["paper"].train
    return BaselinePreset(
        arch={
            "hidden": (512, 512, 256),
            "lstm_hidden": 180,
            "lstm_layers": 2,
            "d_model": 128,
            "n_heads": 4,
            "n_layers": 3,
            "d_ff": 256,
        },
        static=Schedule(lr=t.lr1, batch=t.batch1, epochs=t.epochs1, patience=t.patience1, weight_decay=t.weight_decay),
        sequence=Schedule(
            lr=t.lr2,
            batch=t.batch2,
            epochs=t.epochs2,
            patience=t.patience2,
            chunk=t.chunk2,
            weight_decay=t.weight_decay,
        ),
    )


PRESETS: dict[str, BaselinePreset] = {
    "paper": _paper(),
    # CPU benchmarks (Table I in well under a minute per model on 2 cores).
    "fast": BaselinePreset(
        arch={
            "hidden": (64, 64, 32),
            "lstm_hidden": 32,
            "lstm_layers": 2,
            "d_model": 32,
            "n_heads": 4,
            "n_layers": 2,
            "d_ff": 64,
        },
        static=Schedule(lr=3e-3, batch=256, epochs=40, patience=6),
        sequence=Schedule(lr=3e-3, batch=8, epochs=80, patience=10, chunk=128),
    ),
    # Unit tests: seconds.
    "tiny": BaselinePreset(
        arch={
            "hidden": (16, 16, 8),
            "lstm_hidden": 8,
            "lstm_layers": 1,
            "d_model": 8,
            "n_heads": 2,
            "n_layers": 1,
            "d_ff": 16,
        },
        static=Schedule(lr=3e-3, batch=256, epochs=3, patience=2),
        sequence=Schedule(lr=3e-3, batch=8, epochs=3, patience=2, chunk=64),
    ),
}


def baseline_config(
    kind: str, preset: str, n_inputs: int, window: int = 20, n_tendons: int = 3
) -> tuple[BaselineConfig, Schedule]:
    """The architecture and schedule of baseline ``kind`` in a named preset, for ``n_tendons`` outputs."""
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; known: {', '.join(PRESETS)}")
    p = PRESETS[preset]
    cfg = BaselineConfig(kind=kind, n_inputs=int(n_inputs), window=int(window), n_tendons=int(n_tendons), **p.arch)
    return cfg, (p.sequence if cfg.sequential else p.static)


# ---- modules ------------------------------------------------------------------------------------
class _MLPCore(nn.Module):
    def __init__(self, n_in: int, hidden: tuple[int, ...], n_out: int):
        super().__init__()
        self.body, width = gelu_mlp_body(n_in, hidden)
        self.head = nn.Linear(width, n_out)

    def forward(self, x: Tensor, valid: Tensor | None = None) -> Tensor:
        flat = x.reshape(-1, x.shape[-1])
        return self.head(self.body(flat)).reshape(*x.shape[:-1], self.head.out_features)


class _LSTMCore(nn.Module):
    def __init__(self, n_in: int, hidden: int, layers: int, n_out: int):
        super().__init__()
        self.lstm = nn.LSTM(n_in, hidden, num_layers=layers, batch_first=True)
        self.head = nn.Linear(hidden, n_out)

    def forward(self, x: Tensor, valid: Tensor | None = None) -> Tensor:
        h, _ = self.lstm(x)  # zero initial state: the start of a trajectory (or of a chunk)
        return self.head(h)


class _TransformerCore(nn.Module):
    def __init__(self, cfg: BaselineConfig):
        super().__init__()
        self.embed = nn.Linear(cfg.n_inputs, cfg.d_model)
        self.layers = nn.ModuleList(
            SlidingWindowLayer(cfg.d_model, cfg.n_heads, cfg.window, cfg.d_ff) for _ in range(cfg.n_layers)
        )
        self.norm = nn.LayerNorm(cfg.d_model)
        self.head = nn.Linear(cfg.d_model, cfg.n_tendons)

    def forward(self, x: Tensor, valid: Tensor) -> Tensor:
        h = self.embed(x)
        for layer in self.layers:
            h = layer(h, valid)
        return self.head(self.norm(h))


class BaselineNet(nn.Module):
    """A black-box regressor of the terminal log ratio ``ln T[N, N] - ln T[1, N]``.

    ``forward(x, since_start)`` maps raw inputs ``x`` (B, L, F) to log ratios (B, L, n), one per tendon;
    ``since_start`` (B, L) counts the frames of history available to each frame (only the
    Transformer reads it; the LSTM starts from a zero state at ``L``'s first frame).
    """

    def __init__(self, cfg: BaselineConfig):
        super().__init__()
        self.cfg = cfg
        if cfg.kind == "mlp":
            self.core: nn.Module = _MLPCore(cfg.n_inputs, cfg.hidden, cfg.n_tendons)
        elif cfg.kind == "lstm":
            self.core = _LSTMCore(cfg.n_inputs, cfg.lstm_hidden, cfg.lstm_layers, cfg.n_tendons)
        else:
            self.core = _TransformerCore(cfg)
        # Start at the training mean (a zero head), as g_phi starts at "no residual".
        nn.init.zeros_(self.core.head.weight)
        nn.init.zeros_(self.core.head.bias)
        self.register_buffer("x_mean", torch.zeros(cfg.n_inputs))
        self.register_buffer("x_std", torch.ones(cfg.n_inputs))
        self.register_buffer("y_mean", torch.zeros(cfg.n_tendons))
        self.register_buffer("y_std", torch.ones(cfg.n_tendons))

    def forward(self, x: Tensor, since_start: Tensor | None = None) -> Tensor:
        z = (x - self.x_mean) / self.x_std
        valid = None
        if self.cfg.kind == "transformer":
            if since_start is None:
                since_start = torch.arange(x.shape[1], device=x.device).expand(x.shape[:2])
            lags = torch.arange(self.cfg.window, device=x.device)
            valid = lags[None, None, :] <= since_start[..., None]
        return self.y_mean + self.y_std * self.core(z, valid)


def build_baseline(cfg: BaselineConfig) -> BaselineNet:
    return BaselineNet(cfg)


def count_parameters(net: nn.Module) -> int:
    """Trainable parameters (buffers such as the normalisation statistics excluded)."""
    return sum(p.numel() for p in net.parameters() if p.requires_grad)
