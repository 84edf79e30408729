"""One streaming step of PG-CHTC as an ONNX graph (:class:`~tendon_id.export.spec.CascadeSpec`).

The frame of :class:`learners.cascade.StreamingCascade` (paper Algorithm 1): the unit inputs
of paper Eq. (7) normalised in float64, then per guide ``f_theta`` (BatchNorm folded) and
``g_phi`` in float32, ``ln T += clamp(ln r_MLP + ln(1 + r_TR))`` summed in float64.

The attention caches are explicit state: each layer's keys and values of the last ``h``
frames, oldest first, for every guide's streams (guide ``g`` carries sets ``g + 2 .. N``).
A step shifts them by one frame and appends the new one; the learned lag bias is read
oldest first to match, and frames from before the trajectory's start are masked out by
``n_seen``, the frames seen so far.  Attention does not depend on the order the frames are
stored in, so this computes the torch engine's ring-cache frame, to float32 rounding.
"""

from __future__ import annotations

import numpy as np

from tendon_id.export.onnx_graph import F32, F64, I64, Graph
from tendon_id.export.spec import CascadeSpec, UnitWeights


class _Unit:
    """A unit's weights as initializers, made once (a tied cascade's guides share them)."""

    def __init__(self, g: Graph, unit: UnitWeights, index: int, window: int):
        name = f"unit{index}"
        pair = lambda p, what: (g.const(p[0], f"{name}.{what}.weight"), g.const(p[1], f"{name}.{what}.bias"))  # noqa: E731
        self.backbone = [pair(p, f"backbone{i}") for i, p in enumerate(unit.backbone)]
        self.embed = pair(unit.embed, "embed") if unit.embed is not None else None
        self.layers = []
        for i, layer in enumerate(unit.layers):
            what = f"layer{i}"
            bias = layer.lag_bias[:, ::-1].copy()  # bias[h, lag] read oldest frame first: lag window-1 .. 0
            self.layers.append(
                {
                    "ln1": pair(layer.ln1, f"{what}.norm1"),
                    "qkv": pair(layer.qkv, f"{what}.qkv"),
                    "out": pair(layer.out, f"{what}.out"),
                    "bias": g.const(bias.reshape(bias.shape[0], 1, window), f"{name}.{what}.lag_bias"),
                    "ln2": pair(layer.ln2, f"{what}.norm2"),
                    "ff1": pair(layer.ff1, f"{what}.ff1"),
                    "ff2": pair(layer.ff2, f"{what}.ff2"),
                }
            )
        self.norm = pair(unit.norm, "norm") if unit.norm is not None else None
        self.head = pair(unit.head, "head") if unit.head is not None else None


def _layer_norm(g: Graph, x: str, params: tuple[str, str]) -> str:
    return g.op("LayerNormalization", x, params[0], params[1], axis=-1, epsilon=1e-5)  # nn.LayerNorm's eps


def cascade_graph(spec: CascadeSpec, version: str):
    """The ONNX model of one frame of ``spec`` (inputs, outputs and state as :mod:`tendon_id.export.interface`)."""
    g = Graph()
    n, m = spec.n_modules, spec.n_tendons
    L, H, W, dk, D = spec.n_layers, spec.n_heads, spec.window, spec.d_head, spec.d_model
    angles = g.input("angles", F64, [n, 2])
    actuator = g.input("actuator", F64, [n, m])
    n_seen = g.input("n_seen", I64, [1])
    cache_shape = [L, spec.n_streams, H, W, dk]
    caches = {k: g.input(k, F32, cache_shape) for k in ("keys", "values")} if spec.residual else {}
    units = [_Unit(g, u, i, W) for i, u in enumerate(spec.units)]

    # The unit inputs' geometry (paper Eqs. (2), (3), (7)), float64 then rounded to float32.
    alpha = g.op("Min", g.op("Add", g.half_bends(angles, n), g.f64(spec.alpha_0)), g.f64(np.pi))  # (N-1, 1)
    s = g.op("Sin", angles)
    geo = g.op("Concat", g.rows(s, 0, n - 1), g.rows(s, 1, n), g.op("Cos", alpha), axis=1)  # (N-1, 5)
    mean, std = g.const(spec.mean, "feature_mean"), g.const(spec.std, "feature_std")
    geo_mean, geo_std = g.slice(mean, [0], [5], [0]), g.slice(std, [0], [5], [0])
    t_mean, t_std = g.slice(mean, [5], [5 + m], [0]), g.slice(std, [5], [5 + m], [0])
    geo_n = g.op("Cast", g.op("Div", g.op("Sub", geo, geo_mean), geo_std), to=F32)
    # A cache position holds a frame of this trajectory iff its lag, window - 1 - position, is <= n_seen.
    valid = g.op("GreaterOrEqual", g.const(np.arange(W, dtype=np.int64)), g.op("Sub", g.i64(W - 1), n_seen))

    log_act = g.op("Log", actuator)
    done = [g.rows(log_act, 0, 1)]
    x_t = g.rows(log_act, 1, n)
    new_caches = {k: [[] for _ in range(L)] for k in caches}
    offset = 0
    for k in range(n - 1):
        rows = n - 1 - k
        unit = units[0 if len(units) == 1 else k]
        tn = g.op("Cast", g.op("Div", g.op("Sub", g.op("Exp", x_t), t_mean), t_std), to=F32)
        geo_k = g.op("Expand", g.rows(geo_n, k, k + 1), g.i64(rows, 5))
        x = g.op("Concat", geo_k, tn, axis=1)  # (rows, 5 + m)
        h = x
        for w, b in unit.backbone[:-1]:
            h = g.gelu(g.linear(h, w, b))
        ratio = g.op("Add", g.op("Softplus", g.linear(h, *unit.backbone[-1])), g.f32(0.01))
        lr = g.op("Log", ratio)
        if spec.residual:
            e = g.linear(x, *unit.embed)
            for li, layer in enumerate(unit.layers):
                q, kk, v = g.ops(
                    "Split", [g.linear(_layer_norm(g, e, layer["ln1"]), *layer["qkv"]), g.i64(D, D, D)], 3, axis=1
                )
                heads = lambda t: g.reshape(t, [rows, H, 1, dk])  # noqa: E731
                stored = {}
                for key, new in (("keys", kk), ("values", v)):
                    old = g.reshape(
                        g.slice(caches[key], [li, offset], [li + 1, offset + rows], [0, 1]), [rows, H, W, dk]
                    )
                    shifted = g.op("Concat", g.slice(old, [1], [W], [2]), heads(new), axis=2) if W > 1 else heads(new)
                    stored[key] = shifted
                    new_caches[key][li].append(g.reshape(shifted, [1, rows, H, W, dk]))
                scores = g.op("MatMul", heads(q), g.op("Transpose", stored["keys"], perm=[0, 1, 3, 2]))
                bias = g.op("Where", valid, layer["bias"], g.f32(-np.inf))
                scores = g.op("Add", g.op("Div", scores, g.f32(np.sqrt(dk))), bias)  # (rows, H, 1, W)
                att = g.reshape(g.op("MatMul", g.op("Softmax", scores, axis=-1), stored["values"]), [rows, D])
                e = g.op("Add", e, g.linear(att, *layer["out"]))
                ff = g.linear(g.gelu(g.linear(_layer_norm(g, e, layer["ln2"]), *layer["ff1"])), *layer["ff2"])
                e = g.op("Add", e, ff)
            tr = g.linear(_layer_norm(g, e, unit.norm), *unit.head)
            r_tr = g.op("Mul", g.op("Tanh", tr), g.f32(0.5))
            lr = g.op("Add", lr, g.op("Log", g.op("Add", r_tr, g.f32(1.0))))  # ln(1 + r_TR): ONNX has no log1p
        bound = spec.log_ratio_bound
        lr = g.op("Clip", lr, g.f32(-bound), g.f32(bound))
        out = g.op("Add", x_t, g.op("Cast", lr, to=F64))
        done.append(g.rows(out, 0, 1))  # set k + 2 is final once it has passed guide k + 1
        if rows > 1:
            x_t = g.rows(out, 1, rows)
        offset += rows

    log_hat = g.op("Concat", *done, axis=0)
    tensions = g.op("Concat", g.rows(actuator, 0, 1), g.op("Exp", g.rows(log_hat, 1, n)), axis=0)
    g.output("tensions", tensions, F64, [n, m])
    g.output("n_seen_out", g.op("Min", g.op("Add", n_seen, g.i64(1)), g.i64(W)), I64, [1])
    for key, per_layer in new_caches.items():
        layers = [g.op("Concat", *parts, axis=1) for parts in per_layer]
        g.output(f"{key}_out", g.op("Concat", *layers, axis=0) if L > 1 else layers[0], F32, cache_shape)
    doc = f"{spec.model}: one streaming frame of the PG-CHTC cascade, paper Algorithm 1 (tendon-id export)"
    return g.model(spec.model, doc, version)
