"""One streaming step as a self-contained C99 source and header: the weights as static const arrays, the kernel.

The generated ``PREFIX.c`` includes only its own ``PREFIX.h`` and the C standard library
(``math.h``, ``string.h``, ``stddef.h``); it builds with ``cc -O2 -c PREFIX.c`` and links with
``-lm`` alone.  The kernels (``tendon_id/export/c/*.c``) are fixed text: the source is a prelude
of sizes and numbers, then the kernel, with the weights where it says ``@WEIGHTS@``, then the
four public functions.  Numbers are written so that the compiler reads back the same bits:
float64 in Python's shortest round-trip form, float32 with nine significant digits.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from tendon_id.export.spec import CapstanSpec, CascadeSpec, ExportError

__all__ = ["PREFIX_PATTERN", "c_files", "check_prefix"]

KERNELS = Path(__file__).with_name("c")
#: A C identifier that names the exported functions, types and files.
PREFIX_PATTERN = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,40}")


def check_prefix(prefix: str) -> str:
    """``prefix`` if it is a C identifier (the exported names start with it), else ExportError naming it."""
    if not isinstance(prefix, str) or not PREFIX_PATTERN.fullmatch(prefix):
        raise ExportError(
            f"must be a C identifier (letters, digits, _; not starting with a digit), got {prefix!r}", param="prefix"
        )
    return prefix


def _finite(a: np.ndarray, what: str) -> np.ndarray:
    if not np.all(np.isfinite(a)):
        raise ExportError(f"{what} holds NaN or infinity; a model with non-finite weights cannot be exported")
    return a


def _doubles(a, what: str) -> str:
    a = _finite(np.asarray(a, dtype=np.float64).ravel(), what)
    return ", ".join(repr(float(v)) for v in a)


def _floats(a, what: str) -> str:
    a = _finite(np.asarray(a, dtype=np.float32).ravel(), what)
    rows = [", ".join(_float_literal(v) for v in a[i : i + 8]) for i in range(0, a.size, 8)]
    return ",\n    ".join(rows)


def _float_literal(v) -> str:
    """A float32 as a C literal the compiler reads back to the same bits: nine significant digits, ``f``."""
    text = f"{float(v):.9g}"
    return text + ("f" if "." in text or "e" in text else ".0f")  # "1f" is no C literal, "1.0f" is


def _array(name: str, a, what: str) -> str:
    a = np.asarray(a)
    return f"static const float {name}[{max(a.size, 1)}] = {{\n    {_floats(a, what) or '0.0f'}}};\n"


# ---- the capstan law --------------------------------------------------------------------------


def _capstan(spec: CapstanSpec) -> tuple[str, str, str]:
    n, m = spec.n_modules, spec.n_tendons
    fields = "    int n_seen; /* frames seen since the trajectory started, saturating at 1 */\n"
    if spec.hysteresis:
        fields += (
            f"    double play_y[{n - 1}][{n}][{m}]; /* ln T [ln N] leaving guide g of set s > g (play operator) */\n"
        )
    rows = spec.A.shape[0]
    prelude = f"""#define NM {n}
#define NT {m}
#define NG {n - 1}
#define LAW_ROWS {rows}
#define GATE {dict(dead_zone=1, hard=2).get(spec.gate, 0)}
#define HYSTERESIS {int(spec.hysteresis)}
#define CONSTANT_MU {int(spec.mu_law == "constant")}
static const double ALPHA_0 = {repr(spec.alpha_0)};
"""
    if spec.gate is not None:  # only what the step reads: an unused static const is a compiler warning
        prelude += f"static const double ALPHA_C = {repr(spec.alpha_c)};\n"
    law = "".join(
        f"static const double LAW_{name}[{rows}][{m}] = {{"
        + ", ".join("{" + _doubles(row, f"law {name}") + "}" for row in arr)
        + "};\n"
        for name, arr in (("A", spec.A), ("B", spec.B))
        if name == "B" or spec.mu_law != "constant"
    )
    kernel = (KERNELS / "capstan_kernel.c").read_text()
    return fields, prelude + law, kernel.replace("@WEIGHTS@", "")


# ---- the cascade --------------------------------------------------------------------------------


def _scratch_floats(spec: CascadeSpec) -> tuple[int, int]:
    hidden = [w.shape[1] for w, _ in spec.units[0].backbone[:-1]]
    widest = max(
        [5 + spec.n_tendons, spec.n_tendons, *hidden] + ([3 * spec.d_model, spec.d_ff] if spec.residual else [])
    )
    g = spec.n_guides
    return widest, g * (5 + spec.n_tendons + 2 * widest + spec.d_model + 2 * spec.n_tendons)


def _linear(name: str, pair, what: str) -> tuple[str, str]:
    w, b = pair
    text = _array(f"{name}_W", w, what) + _array(f"{name}_B", b, what)
    return text, f"{{{name}_W, {name}_B, {w.shape[0]}, {w.shape[1]}}}"


def _norm(name: str, pair, what: str) -> tuple[str, str]:
    return _array(f"{name}_G", pair[0], what) + _array(f"{name}_B", pair[1], what), f"{{{name}_G, {name}_B}}"


def _unit(u: int, unit) -> tuple[str, str]:
    """A unit's arrays and its ``unit_t`` initializer."""
    text, parts = [], []
    backbone = []
    for i, pair in enumerate(unit.backbone):
        t, init = _linear(f"U{u}_BB{i}", pair, f"unit {u} f_theta")
        text.append(t)
        backbone.append(init)
    parts.append(f".backbone = {{{', '.join(backbone)}}}")
    if unit.embed is not None:
        t, init = _linear(f"U{u}_EMBED", unit.embed, f"unit {u} g_phi")
        text.append(t)
        parts.append(f".embed = {init}")
        layers = []
        for i, layer in enumerate(unit.layers):
            p, what, fields = f"U{u}_L{i}", f"unit {u} g_phi layer {i}", []
            for key in ("ln1", "qkv", "out", "ln2", "ff1", "ff2"):
                make = _norm if key.startswith("ln") else _linear
                t, init = make(f"{p}_{key.upper()}", getattr(layer, key), what)
                text.append(t)
                fields.append(f".{key} = {init}")
            text.append(_array(f"{p}_LAG_BIAS", layer.lag_bias, what))
            fields.append(f".lag_bias = {p}_LAG_BIAS")
            layers.append("{" + ", ".join(fields) + "}")
        parts.append(f".layers = {{{', '.join(layers)}}}")
        for key, make in (("norm", _norm), ("head", _linear)):
            t, init = make(f"U{u}_{key.upper()}", getattr(unit, key), f"unit {u} g_phi")
            text.append(t)
            parts.append(f".{key} = {init}")
    return "".join(text), "    {" + ",\n     ".join(parts) + "}"


def _cascade(spec: CascadeSpec) -> tuple[str, str, str]:
    widest, scratch = _scratch_floats(spec)
    cache = 2 * spec.n_layers * spec.n_streams * spec.window * spec.d_model if spec.residual else 0
    fields = (
        f"    int n_seen; /* frames seen since the trajectory started, saturating at {spec.window} */\n"
        "    int slot; /* the ring slot the next frame's keys and values go to */\n"
        f"    float cache[{max(cache, 1)}]; /* attention keys then values [layer][stream][head][slot][channel] */\n"
        f"    float scratch[{scratch}]; /* work memory of one step */\n"
    )
    hidden = len(spec.units[0].backbone) - 1
    prelude = f"""#define NM {spec.n_modules}
#define NT {spec.n_tendons}
#define NF (5 + NT)
#define NG {spec.n_guides}
#define N_HIDDEN {hidden}
#define RESIDUAL {int(spec.residual)}
#define DM {spec.d_model}
#define NHEAD {spec.n_heads}
#define DK {spec.d_head}
#define WIN {spec.window}
#define DFF {spec.d_ff}
#define NLAYER {spec.n_layers if spec.residual else 0}
#define N_UNITS {len(spec.units)}
#define NSTREAMS {spec.n_streams}
#define WIDEST {widest}
#define LOG_RATIO_BOUND {float(spec.log_ratio_bound)!r}f
static const double NORM_MEAN[NF] = {{{_doubles(spec.mean, "the input normalisation")}}};
static const double NORM_STD[NF] = {{{_doubles(spec.std, "the input normalisation")}}};
static const double ALPHA_0 = {spec.alpha_0!r};
"""
    arrays, inits = zip(*(_unit(i, u) for i, u in enumerate(spec.units)))
    weights = "".join(arrays) + "static const unit_t UNITS[N_UNITS] = {\n" + ",\n".join(inits) + "};\n"
    kernel = (KERNELS / "cascade_kernel.c").read_text()
    return fields, prelude, kernel.replace("@WEIGHTS@", weights)


# ---- the files --------------------------------------------------------------------------------


def c_files(spec: CapstanSpec | CascadeSpec, prefix: str, version: str) -> dict[str, str]:
    """``{"PREFIX.h": text, "PREFIX.c": text}`` of one streaming step of ``spec``."""
    prefix = check_prefix(prefix)
    fields, prelude, kernel = _capstan(spec) if isinstance(spec, CapstanSpec) else _cascade(spec)
    upper = prefix.upper()
    n, m = spec.n_modules, spec.n_tendons
    made = f"generated by tendon-id {version} (tendon-id export)"
    header = f"""/* {prefix}.h: one streaming step of a fitted {spec.model} model, {made}.
 *
 * Per trajectory: {prefix}_reset(&state); then per frame {prefix}_step(&state, angles, actuator, tensions).
 * Arrays are row-major float64: angles N x 2 joint angles [rad] (x, y of joints 1..N), actuator N x m
 * actuator-side tensions T[1, j, i] [N], tensions N x m joint-side estimates T_hat[j, j, i] [N].
 */
#ifndef {upper}_H
#define {upper}_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {{
#endif

#define {upper}_N_MODULES {n} /* N: joints and tendon sets */
#define {upper}_N_TENDONS {m} /* m: tendons per set */

typedef struct {prefix}_state {{
{fields}}} {prefix}_state;

/* Zero the whole state: call once before the first step (it also resets). */
void {prefix}_init({prefix}_state *state);
/* Forget the history: the next step starts a trajectory. */
void {prefix}_reset({prefix}_state *state);
/* One frame: writes tensions and updates the state; returns 0.  Returns 1, writing nothing and
 * leaving the state as it was, if an angle or tension is not finite or a tension is not > 0. */
int {prefix}_step({prefix}_state *state, const double *angles, const double *actuator, double *tensions);
/* sizeof({prefix}_state) [bytes], for a caller without this header (Python's ctypes). */
size_t {prefix}_state_size(void);

#ifdef __cplusplus
}}
#endif

#endif /* {upper}_H */
"""
    source = f"""/* {prefix}.c: one streaming step of a fitted {spec.model} model, {made}.
 *
 * Self-contained C99: build with `cc -O2 -c {prefix}.c` and link with -lm; see {prefix}.h for the interface.
 */
#include "{prefix}.h"

#include <math.h>
#include <string.h>

typedef {prefix}_state state_t;

{prelude}
{kernel}
void {prefix}_init({prefix}_state *state) {{
    memset(state, 0, sizeof *state);
    state_reset(state);
}}

void {prefix}_reset({prefix}_state *state) {{ state_reset(state); }}

int {prefix}_step({prefix}_state *state, const double *angles, const double *actuator, double *tensions) {{
    return state_step(state, angles, actuator, tensions);
}}

size_t {prefix}_state_size(void) {{ return sizeof(state_t); }}
"""
    return {f"{prefix}.h": header, f"{prefix}.c": source}
