"""Sizes and schedules of PG-CHTC: the paper's, and a fast one for CPUs, tests and docs."""

from __future__ import annotations

from dataclasses import dataclass, field, replace


@dataclass(frozen=True)
class UnitConfig:
    """Architecture of one PG-CHTM unit (paper Section IV-B).

    Parameters
    ----------
    hidden : tuple of int
        Widths of ``f_theta``'s hidden layers (paper: 512/512/256).
    d_model, n_heads, n_layers : int
        The causal Transformer ``g_phi`` (paper: 128, 4, 3).
    window : int
        History window ``h`` in frames (paper: 20, i.e. 2 s at 10 Hz): each attention layer
        looks at the last ``h`` frames.
    d_ff : int
        Feed-forward width of ``g_phi``'s layers.
    temporal_residual : bool
        Include ``g_phi`` (the "w/o Temporal Residual" ablation sets it False).
    """

    hidden: tuple[int, ...] = (512, 512, 256)
    d_model: int = 128
    n_heads: int = 4
    n_layers: int = 3
    window: int = 20
    d_ff: int = 256
    temporal_residual: bool = True

    def __post_init__(self) -> None:
        if self.window < 1 or self.d_model % self.n_heads:
            raise ValueError("window must be >= 1 and d_model divisible by n_heads")


@dataclass(frozen=True)
class TrainConfig:
    """Two-stage schedule (paper Section IV-B): stage 1 pretrains ``f_theta``, stage 2 ``g_phi``."""

    lr1: float = 1e-5
    batch1: int = 128
    epochs1: int = 1500
    patience1: int = 100
    lr2: float = 1e-3
    chunk2: int = 1024
    batch2: int = 8
    epochs2: int = 120
    patience2: int = 15
    weight_decay: float = 1e-4


@dataclass(frozen=True)
class Preset:
    unit: UnitConfig = field(default_factory=UnitConfig)
    train: TrainConfig = field(default_factory=TrainConfig)


PRESETS = {
    "paper": Preset(),
    # Small enough that the whole Table II benchmark trains on 2 CPU cores in minutes.
    "fast": Preset(
        unit=UnitConfig(hidden=(64, 64, 32), d_model=32, n_heads=4, n_layers=2, window=20, d_ff=64),
        train=TrainConfig(
            lr1=3e-3, batch1=256, epochs1=30, patience1=5, lr2=2e-3, chunk2=256, batch2=16, epochs2=6, patience2=2
        ),
    ),
    # For unit tests: seconds, not minutes.
    "tiny": Preset(
        unit=UnitConfig(hidden=(16, 16, 8), d_model=8, n_heads=2, n_layers=1, window=5, d_ff=16),
        train=TrainConfig(
            lr1=3e-3, batch1=256, epochs1=3, patience1=2, lr2=2e-3, chunk2=64, batch2=8, epochs2=2, patience2=1
        ),
    ),
}


def preset(name: str, **unit_overrides) -> Preset:
    """A named preset, with unit settings overridden (e.g. ``window=40``)."""
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; known: {', '.join(PRESETS)}")
    p = PRESETS[name]
    return replace(p, unit=replace(p.unit, **unit_overrides)) if unit_overrides else p
