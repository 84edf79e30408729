"""One streaming step of a capstan law as an ONNX graph (:class:`~tendon_id.export.spec.CapstanSpec`).

The same arithmetic, in the same order and in float64, as the model's blocks
(:mod:`tendon_id.zoo.chain`) and :class:`~tendon_id.zoo.capstan_stream.CapstanStream`:

* ``alpha_k = min(min(|theta_k| / 2 + |theta_{k+1}| / 2, pi) + alpha_0, pi)`` (paper Eq. (3));
* the contact gate's share of it, ``max(alpha - alpha_c, 0) / alpha`` or ``1[alpha > alpha_c]``;
* ``phi = (A cos(alpha) + B) alpha_eff`` (paper Eqs. (4)-(5); ``B alpha_eff`` for a constant mu);
* through each guide, ``lo, hi = x -/+ phi`` and ``y = clamp(y_prev, lo, hi)`` with hysteresis
  (``lo`` on a trajectory's first frame, and always without hysteresis).
"""

from __future__ import annotations

import numpy as np

from tendon_id.export.onnx_graph import F64, I64, Graph
from tendon_id.export.spec import CapstanSpec


def capstan_graph(spec: CapstanSpec, version: str):
    """The ONNX model of one frame of ``spec`` (inputs, outputs and state as :mod:`tendon_id.export.interface`)."""
    g = Graph()
    n, m = spec.n_modules, spec.n_tendons
    angles = g.input("angles", F64, [n, 2])
    actuator = g.input("actuator", F64, [n, m])
    n_seen = g.input("n_seen", I64, [1])
    play_y = g.input("play_y", F64, [n - 1, n, m]) if spec.hysteresis else None

    pi = g.f64(np.pi)
    bend = g.op("Min", g.half_bends(angles, n), pi)  # the joints' part of the wrap, (N-1, 1)
    alpha = g.op("Min", g.op("Add", bend, g.f64(spec.alpha_0)), pi)
    if spec.gate == "dead_zone":
        pressed = g.op("Max", g.op("Sub", alpha, g.f64(spec.alpha_c)), g.f64(0.0))
        positive = g.op("Greater", alpha, g.f64(0.0))
        # Where alpha is 0 the share is 0; the division there is never used (Where picks the 0).
        safe = g.op("Where", positive, alpha, g.f64(1.0))
        share = g.op("Where", positive, g.op("Div", pressed, safe), g.f64(0.0))
        scaled = g.op("Mul", alpha, share)
    elif spec.gate == "hard":
        scaled = g.op("Mul", alpha, g.op("Cast", g.op("Greater", alpha, g.f64(spec.alpha_c)), to=F64))
    else:
        scaled = alpha
    B = g.const(spec.B, "law_B")
    if spec.mu_law == "constant":
        phi = g.op("Mul", B, scaled)  # (N-1, m)
    else:
        mu = g.op("Add", g.op("Mul", g.const(spec.A, "law_A"), g.op("Cos", alpha)), B)
        phi = g.op("Mul", mu, scaled)
    if spec.A.shape[0] == 1:
        phi = g.op("Expand", phi, g.i64(n - 1, m))

    started = g.op("Greater", n_seen, g.i64(0))
    x = g.rows(g.op("Log", actuator), 1, n)  # ln T entering guide 1 of sets 2..N
    done = [g.rows(actuator, 0, 1)]  # set 1 passes no guide: its reading, exactly
    kept = []
    for k in range(n - 1):
        rows = n - 1 - k  # sets k+2..N pass guide k+1
        p = g.rows(phi, k, k + 1)
        lo = g.op("Sub", x, p)
        y = lo
        if spec.hysteresis:
            hi = g.op("Add", x, p)
            prev = g.reshape(g.slice(play_y, [k, k + 1], [k + 1, n], [0, 1]), [rows, m])
            y = g.op("Where", started, g.op("Min", g.op("Max", prev, lo), hi), lo)
            pad = g.const(np.zeros((k + 1, m)))
            kept.append(g.reshape(g.op("Concat", pad, y, axis=0), [1, n, m]))
        done.append(g.op("Exp", g.rows(y, 0, 1)))
        if rows > 1:
            x = g.rows(y, 1, rows)
    g.output("tensions", g.op("Concat", *done, axis=0), F64, [n, m])
    g.output("n_seen_out", g.op("Min", g.op("Add", n_seen, g.i64(1)), g.i64(1)), I64, [1])
    if spec.hysteresis:
        g.output("play_y_out", g.op("Concat", *kept, axis=0), F64, [n - 1, n, m])
    doc = f"{spec.model}: one streaming frame of the capstan law (tendon-id export)"
    return g.model(spec.model, doc, version)
