"""What an exported streaming step computes, read from a fitted model: numbers and sizes, no framework objects.

Two laws export (:func:`step_spec`):

:class:`CapstanSpec`
    A capstan model whose blocks stream (:data:`~tendon_id.zoo.capstan_stream.STREAMED_BLOCKS`):
    per guide ``phi = mu(alpha) alpha_eff`` (paper Eqs. (3)-(6)) and, with hysteresis, the
    play operator ``y = clamp(y_prev, ln T_in - phi, ln T_in + phi)`` (paper §III-B); its state
    is ``y`` per guide, set and tendon.
:class:`CascadeSpec`
    PG-CHTC (paper Algorithm 1): per guide, ``f_theta`` with BatchNorm folded in, times
    ``1 + r_TR`` of the causal Transformer ``g_phi`` over the last ``h`` frames; its state is
    each attention layer's keys and values of those frames, per guide and set.

Both read the module count ``N`` and the tendons per set ``m`` from the fitted arrays, never
from a constant, so they follow the model (the tendon count per set is being generalised).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from tendon_id.errors import ConfigError
from tendon_id.zoo.capstan import CapstanModel
from tendon_id.zoo.capstan_stream import STREAMED_BLOCKS, unstreamed_blocks
from tendon_id.zoo.guard import PriorGuardWarning

__all__ = ["CapstanSpec", "CascadeSpec", "ExportError", "LayerWeights", "UnitWeights", "step_spec"]

#: Models that export, for the messages (the capstan models count when their blocks stream).
EXPORTED_MODELS = ("pg-chtc", "capstan-simple", "capstan-contact", "capstan-nonsmooth", "capstan-const-mu", "capstan")


class ExportError(ConfigError):
    """The model cannot be exported (which model, why, and what can be)."""


@dataclass(frozen=True)
class CapstanSpec:
    """A streamed capstan law (all angles in rad, tensions in ln N).

    Attributes
    ----------
    model : str
        Registry name.
    n_modules, n_tendons : int
        ``N`` and tendons per set ``m``.
    mu_law : {"affine-cosine", "constant"}
    A, B : ndarray, shape (G, m)
        The law, ``G = 1`` (tied) or ``N - 1``; the constant law's ``mu`` is ``B``.
    alpha_0 : float
        Routing wrap [rad], ``>= 0`` (as the routing block applies it).
    gate : {None, "dead_zone", "hard"}
        The contact gate, if any.
    alpha_c : float
        Clearance angle [rad], ``>= 0`` (0 without a gate).
    hysteresis : bool
        Stick/slip through the play operator (else forward slip, ``y = lo``).
    """

    model: str
    n_modules: int
    n_tendons: int
    mu_law: str
    A: np.ndarray
    B: np.ndarray
    alpha_0: float
    gate: str | None
    alpha_c: float
    hysteresis: bool


@dataclass(frozen=True)
class LayerWeights:
    """One pre-norm attention layer of ``g_phi``; Linear weights transposed, ``(in, out)``, float32."""

    ln1: tuple[np.ndarray, np.ndarray]
    qkv: tuple[np.ndarray, np.ndarray]
    out: tuple[np.ndarray, np.ndarray]
    lag_bias: np.ndarray  # (H, window): bias[h, lag]
    ln2: tuple[np.ndarray, np.ndarray]
    ff1: tuple[np.ndarray, np.ndarray]
    ff2: tuple[np.ndarray, np.ndarray]


@dataclass(frozen=True)
class UnitWeights:
    """One PG-CHTM unit: ``f_theta``'s Linear layers (BatchNorm folded), then ``g_phi``'s, float32."""

    backbone: list[tuple[np.ndarray, np.ndarray]]  # hidden layers then the head, (in, out) and (out,)
    embed: tuple[np.ndarray, np.ndarray] | None
    layers: list[LayerWeights]
    norm: tuple[np.ndarray, np.ndarray] | None
    head: tuple[np.ndarray, np.ndarray] | None


@dataclass(frozen=True)
class CascadeSpec:
    """A PG-CHTC cascade's streaming step.

    Attributes
    ----------
    model : str
    n_modules, n_tendons : int
        ``N`` and tendons per set ``m`` (the unit reads ``5 + m`` features, paper Eq. (7)).
    alpha_0 : float
        The routing wrap of the unit inputs' backbone wrap [rad] (the prior's fitted one).
    mean, std : ndarray, shape (5 + m,)
        Channel normalisation of the unit inputs (float64 of the float32 buffers).
    units : list of UnitWeights
        One (tied) or one per guide.
    residual : bool
        Whether ``g_phi`` is present.
    d_model, n_heads, window, n_layers, d_ff : int
        ``g_phi``'s sizes.
    log_ratio_bound : float
        The clamp of each guide's ``ln r``.
    """

    model: str
    n_modules: int
    n_tendons: int
    alpha_0: float
    mean: np.ndarray
    std: np.ndarray
    units: list[UnitWeights]
    residual: bool
    d_model: int
    n_heads: int
    window: int
    n_layers: int
    d_ff: int
    log_ratio_bound: float

    @property
    def n_guides(self) -> int:
        return self.n_modules - 1

    @property
    def n_streams(self) -> int:
        """Streams of ring caches, over every guide: guide ``g`` (0-based) carries ``N - 1 - g`` sets."""
        return self.n_guides * (self.n_guides + 1) // 2

    @property
    def d_head(self) -> int:
        return self.d_model // self.n_heads


def step_spec(model) -> CapstanSpec | CascadeSpec:
    """The streaming step of a fitted ``model``, for the exporters.

    Raises
    ------
    ExportError
        For a model that does not export, naming it and what does.
    """
    model.check_fitted()
    if isinstance(model, CapstanModel):
        return _capstan_spec(model)
    if getattr(model, "name", None) == "pg-chtc":
        return _cascade_spec(model)
    raise ExportError(
        f"model {getattr(model, 'name', type(model).__name__)!r} cannot be exported; the models that can: "
        f"{', '.join(EXPORTED_MODELS)} (formats onnx and c)"
    )


def _capstan_spec(model: CapstanModel) -> CapstanSpec:
    others = unstreamed_blocks(model)
    if others:
        raise ExportError(
            f"model {model.name!r} has the block(s) {', '.join(others)}, which the exported step does not cover; "
            f"a capstan model exports (formats onnx and c) with {', '.join(STREAMED_BLOCKS)} blocks only"
        )
    values = model.block_params_
    gate = next((b.gate for b in model.block_objects if b.name == "contact"), None)
    A = np.asarray(model.A_, dtype=np.float64)
    B = np.asarray(model.B_, dtype=np.float64)
    if A.shape != B.shape or A.ndim != 2 or A.shape[0] not in (1, model.n_modules_ - 1):
        raise ExportError(f"model {model.name!r}: its law A {A.shape}, B {B.shape} is not per guide or tied")
    return CapstanSpec(
        model=model.name,
        n_modules=int(model.n_modules_),
        n_tendons=int(A.shape[1]),
        mu_law=model.mu_law,
        A=A,
        B=B,
        # What the blocks apply: a rounding below a bound of 0 is no wrap (RoutingWrap, ContactGate).
        alpha_0=max(float(values["routing"]["alpha_0"]), 0.0),
        gate=gate,
        alpha_c=max(float(values["contact"]["alpha_c"]), 0.0) if gate is not None else 0.0,
        hysteresis=any(b.name == "hysteresis" for b in model.block_objects),
    )


def _cascade_spec(model) -> CascadeSpec:
    import torch

    from learners.cascade import LOG_RATIO_BOUND, folded_backbone

    if model.uses_prior_:
        raise ExportError(
            "this pg-chtc model predicts with its prior capstan-nonsmooth (the guard found the cascade worse and "
            "fallback=True): export that prior instead (formats onnx and c), e.g. fit capstan-nonsmooth"
        )
    if model.prior_kinds_:
        warnings.warn(
            f"pg-chtc exports its cascade for every kind of motion: a trajectory's kind is known only once it has "
            f"ended, so the prior it predicts {' and '.join(model.prior_kinds_)} trajectories with in batch is not "
            "exported",
            PriorGuardWarning,
            stacklevel=4,
        )
    cascade = model.cascade_
    cfg = cascade.cfg

    def f32(t) -> np.ndarray:
        return t.detach().to("cpu", torch.float32).numpy().copy()

    def linear_t(lin) -> tuple[np.ndarray, np.ndarray]:
        return f32(lin.weight).T.copy(), f32(lin.bias)

    units = []
    with torch.no_grad():
        for unit in cascade.units:
            backbone = [(f32(w), f32(b)) for w, b in folded_backbone(unit.backbone)]
            r = unit.residual
            layers = []
            if r is not None:
                for layer in r.layers:
                    a = layer.attn
                    layers.append(
                        LayerWeights(
                            ln1=(f32(layer.norm1.weight), f32(layer.norm1.bias)),
                            qkv=linear_t(a.qkv),
                            out=linear_t(a.out),
                            lag_bias=f32(a.lag_bias),
                            ln2=(f32(layer.norm2.weight), f32(layer.norm2.bias)),
                            ff1=linear_t(layer.ff[0]),
                            ff2=linear_t(layer.ff[2]),
                        )
                    )
            units.append(
                UnitWeights(
                    backbone=backbone,
                    embed=linear_t(r.embed) if r is not None else None,
                    layers=layers,
                    norm=(f32(r.norm.weight), f32(r.norm.bias)) if r is not None else None,
                    head=linear_t(r.head) if r is not None else None,
                )
            )
    m = int(units[0].backbone[-1][1].shape[0])  # tendons per set: the width of f_theta's head
    mean = cascade.feature_mean.detach().double().numpy().copy()
    if mean.shape != (5 + m,):
        raise ExportError(f"pg-chtc: {mean.shape[0]} unit inputs do not match {m} tendons per set (5 + {m} expected)")
    return CascadeSpec(
        model=model.name,
        n_modules=int(model.n_modules_),
        n_tendons=m,
        alpha_0=float(model.alpha_0_),
        mean=mean,
        std=cascade.feature_std.detach().double().numpy().copy(),
        units=units,
        residual=bool(cfg.temporal_residual),
        d_model=int(cfg.d_model),
        n_heads=int(cfg.n_heads),
        window=int(cfg.window),
        n_layers=int(cfg.n_layers),
        d_ff=int(cfg.d_ff),
        log_ratio_bound=float(LOG_RATIO_BOUND),
    )
