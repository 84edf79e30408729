"""A PG-CHTM unit's parameters in the streaming kernel's layout (``streaming_kernel.c``).

One flat float32 array per unit, in the order the kernel reads it: ``f_theta``'s Linear
layers with BatchNorm folded in, then ``g_phi``'s.  Each Linear weight is transposed,
(in, out), and stored in column panels (:func:`panels`; ``streaming_gemm.h`` says why);
biases, norms and lag biases are stored as they are.  :func:`half_copy` gives the same
array as IEEE binary16 bits for the kernel's half-precision products.
"""

from __future__ import annotations

import numpy as np
import torch

from learners.cascade import folded_backbone

#: Weight precisions of the native engine: float32 (the reference) or an IEEE binary16 copy.
WEIGHT_FORMATS = ("float32", "float16")
FLOAT16_MAX = float(np.finfo(np.float16).max)


def as_f32(t: torch.Tensor) -> np.ndarray:
    """A tensor as a flat float32 numpy array (on the CPU, detached)."""
    return t.detach().to("cpu", torch.float32).numpy().ravel()


def panels(weight: np.ndarray, width: int) -> np.ndarray:
    """A transposed Linear weight (in, out) in the kernel's panel layout, flat.

    Its ``out // width`` column panels, each (in, width) row-major, then the last ``out % width``
    columns row-major (``streaming_gemm.h`` says why).
    """
    k, n = weight.shape
    full = n - n % width
    body = weight[:, :full].reshape(k, full // width, width).transpose(1, 0, 2)
    return np.concatenate([body.ravel(), weight[:, full:].ravel()])


def pack_unit(unit, width: int) -> np.ndarray:
    """One unit's parameters in the kernel's order (see ``backbone_step`` and ``residual_step`` in
    streaming_kernel.c), Linear weights in panels of ``width`` columns (the kernel's
    ``pgchtc_panel_width``).
    """

    def weight(t: torch.Tensor) -> np.ndarray:  # (in, out)
        return panels(as_f32(t).reshape(t.shape), width)

    with torch.no_grad():
        parts = []
        for w, b in folded_backbone(unit.backbone):
            parts += [weight(w), as_f32(b)]
        r = unit.residual
        if r is not None:
            parts += [weight(r.embed.weight.T), as_f32(r.embed.bias)]
            for layer in r.layers:
                a, ff1, ff2 = layer.attn, layer.ff[0], layer.ff[2]
                parts += [
                    as_f32(layer.norm1.weight),
                    as_f32(layer.norm1.bias),
                    weight(a.qkv.weight.T),
                    as_f32(a.qkv.bias),
                    weight(a.out.weight.T),
                    as_f32(a.out.bias),
                    as_f32(a.lag_bias),
                    as_f32(layer.norm2.weight),
                    as_f32(layer.norm2.bias),
                    weight(ff1.weight.T),
                    as_f32(ff1.bias),
                    weight(ff2.weight.T),
                    as_f32(ff2.bias),
                ]
            parts += [as_f32(r.norm.weight), as_f32(r.norm.bias), weight(r.head.weight.T), as_f32(r.head.bias)]
    return np.ascontiguousarray(np.concatenate(parts), dtype=np.float32)


def half_copy(packed: np.ndarray, unit: int) -> np.ndarray:
    """A packed unit as binary16 bits (round to nearest even), for the kernel's half-precision products.

    Raises
    ------
    ValueError
        If a parameter is not finite or beyond float16's range (``unit`` names it).
    """
    big = float(np.max(np.abs(packed), initial=0.0))
    if not np.isfinite(big) or big > FLOAT16_MAX:
        raise ValueError(
            f"weights='float16': unit {unit} has a parameter of magnitude {big:.3g}, beyond float16's "
            f"{FLOAT16_MAX:g}; stream this model with weights='float32'"
        )
    return packed.astype(np.float16).view(np.uint16)
