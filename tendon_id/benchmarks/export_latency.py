"""Latency of an exported streaming step beside the Python streamer's, in one run (part of the latency benchmark).

For each model, the same frames are stepped by ``streamer()`` (for pg-chtc its default engine,
the project's C kernel where it builds), by the exported C step and by the exported ONNX graph
in onnxruntime (one thread).  The C step is timed inside C, by a small driver that reads the
frames from a file and times each step with ``clock_gettime`` (what a controller written in C
pays), built as the export says (``-O2``) and for this CPU (``-O3 -march=native``, where the
compiler vectorises the loops), and through ctypes from Python (what
:class:`~tendon_id.export.run.CStep` pays, a few microseconds more).  Each figure is the median
over the frames after the first 10; the agreement of each export with the streamer over the
same frames is reported beside it.
"""

from __future__ import annotations

import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from tendon_id.export import export_model
from tendon_id.export.run import CStep, OnnxStep, find_compiler

__all__ = ["exported_latency", "format_exported"]

#: Times each step of a recording in C: frames in (binary float64: a reset flag, angles, actuator), ns out.
DRIVER = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "PREFIX.h"
#define N PREFIX_UPPER_N_MODULES
#define M PREFIX_UPPER_N_TENDONS
int main(int argc, char **argv) {
    FILE *in = fopen(argv[1], "rb");
    static PREFIX_state s;
    double frame[1 + 2 * N + N * M], out[N * M];
    struct timespec a, b;
    if (!in) return 2;
    PREFIX_init(&s);
    while (fread(frame, sizeof frame, 1, in) == 1) {
        if (frame[0] != 0.0) PREFIX_reset(&s);
        clock_gettime(CLOCK_MONOTONIC, &a);
        int rc = PREFIX_step(&s, frame + 1, frame + 1 + 2 * N, out);
        clock_gettime(CLOCK_MONOTONIC, &b);
        if (rc) return 3;
        printf("%ld %.17g\n", (b.tv_sec - a.tv_sec) * 1000000000L + (b.tv_nsec - a.tv_nsec), out[N * M - 1]);
    }
    (void)argc;
    return 0;
}
"""


def _timed(stepper, angles, actuator, reset) -> tuple[np.ndarray, float]:
    """Every frame's estimates and the median time per frame after the first 10 [ms]."""
    times, outs = [], []
    for t in range(len(angles)):
        if reset[t]:
            stepper.reset()
        s = time.perf_counter()
        outs.append(stepper.step(angles[t], actuator[t]))
        times.append(time.perf_counter() - s)
    return np.stack(outs), float(np.median(times[10:]) * 1e3)


#: The build line of the export (``-O2``), and one for a known CPU, where the compiler vectorises the loops.
BUILDS = {"c_ms": ("-O2",), "c_native_ms": ("-O3", "-march=native")}


def _in_c(cc: str, folder: Path, angles, actuator, reset, flags: tuple[str, ...]) -> tuple[np.ndarray, float]:
    """The exported C step built with ``flags`` and timed inside C: the last set's last tension of every frame,
    and the median [ms]."""
    prefix = "tendon_model"
    driver = DRIVER.replace("PREFIX_UPPER", prefix.upper()).replace("PREFIX", prefix)
    (folder / "driver.c").write_text(driver)
    frames = np.concatenate(
        [reset[:, None].astype(np.float64), angles.reshape(len(angles), -1), actuator.reshape(len(angles), -1)], axis=1
    )
    (folder / "frames.bin").write_bytes(np.ascontiguousarray(frames, dtype=np.float64).tobytes())
    exe = folder / "driver"
    cmd = [cc, *flags, "-o", str(exe), str(folder / "driver.c"), str(folder / f"{prefix}.c"), "-lm"]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    lines = subprocess.run([str(exe), str(folder / "frames.bin")], check=True, capture_output=True, text=True)
    ns, last = np.loadtxt(lines.stdout.splitlines(), ndmin=2).T
    return last, float(np.median(ns[10:]) * 1e-6)


def exported_latency(models: dict, angles: np.ndarray, actuator: np.ndarray, reset: np.ndarray) -> list[dict]:
    """Per-frame latency of ``streamer()``, the exported C step and the exported ONNX step, for each model.

    Parameters
    ----------
    models : dict
        Name -> fitted model (pg-chtc, capstan-nonsmooth, ...).
    angles : ndarray, shape (T, N, 2)
        Joint angles [rad].
    actuator : ndarray, shape (T, N, m)
        Actuator-side tensions [N].
    reset : ndarray of bool, shape (T,)
        Trajectory starts.

    Returns
    -------
    list of dict
        Per model: ``streamer_ms``, ``c_ms`` (timed in C, ``-O2``), ``c_native_ms`` (``-O3 -march=native``),
        ``c_ctypes_ms``, ``onnx_ms`` [ms per frame],
        ``c_speedup`` and ``onnx_speedup`` (the streamer's time over the export's), and the exports'
        ``*_max_abs_N`` [N] and ``*_max_rel`` deviation from the streamer; None where no compiler or no
        onnxruntime is found (``why`` says which).
    """
    cc = find_compiler()
    rows = []
    for name, model in models.items():
        stream = model.streamer()
        ref, stream_ms = _timed(stream, angles, actuator, reset)
        row = {"model": name, "engine": getattr(stream, "engine_name", "numpy"), "streamer_ms": stream_ms}
        with tempfile.TemporaryDirectory(prefix="tendon-id-latency-") as tmp:
            tmp = Path(tmp)
            for fmt in ("c", "onnx"):
                row.update(
                    {f"{fmt}_ms": None, f"{fmt}_speedup": None, f"{fmt}_max_abs_N": None, f"{fmt}_max_rel": None}
                )
                if fmt == "c" and cc is None:
                    row["why"] = "C: no C compiler found"
                    continue
                try:
                    folder = export_model(model, fmt, tmp / fmt)
                    runner = CStep(folder) if fmt == "c" else OnnxStep(folder)
                except ImportError as exc:  # onnxruntime missing: the export extra
                    row["why"] = "; ".join(filter(None, [row.get("why"), f"ONNX: {exc}"]))
                    continue
                out, ms = _timed(runner, angles, actuator, reset)
                if fmt == "c":
                    last, ms_c = _in_c(cc, folder, angles, actuator, reset, BUILDS["c_ms"])
                    row.update(c_ctypes_ms=ms, c_same_in_c=bool(np.array_equal(last, out[:, -1, -1])))
                    try:  # a compiler without -march=native (or another CPU family's flags): not measured
                        row["c_native_ms"] = _in_c(cc, folder, angles, actuator, reset, BUILDS["c_native_ms"])[1]
                    except subprocess.CalledProcessError:
                        row["c_native_ms"] = None
                    ms = ms_c
                row[f"{fmt}_ms"], row[f"{fmt}_speedup"] = ms, stream_ms / ms
                row[f"{fmt}_max_abs_N"] = float(np.max(np.abs(out - ref)))
                row[f"{fmt}_max_rel"] = float(np.max(np.abs(out / ref - 1.0)))
        rows.append(row)
    return rows


def format_exported(rows: list[dict]) -> list[str]:
    """Lines of the latency table: each model's streamer and its exports [ms/frame], with their agreement."""
    lines = ["  exported step against the Python streamer (median ms/frame; max deviation from the streamer):"]
    for r in rows:
        lines.append(f"    {r['model']}: streamer ({r['engine']}) {r['streamer_ms']:.4f} ms")
        if r.get("c_ms") is not None:
            lines.append(
                f"      C (timed in C) {r['c_ms']:.4f} ms, streamer/C {r['c_speedup']:.1f}; through ctypes "
                f"{r['c_ctypes_ms']:.4f} ms; {r['c_max_abs_N']:.1e} N ({r['c_max_rel']:.1e} relative)"
            )
            if r.get("c_native_ms") is not None:
                lines.append(
                    f"      C built with -O3 -march=native (timed in C) {r['c_native_ms']:.4f} ms, "
                    f"streamer/C {r['streamer_ms'] / r['c_native_ms']:.1f}"
                )
        if r.get("onnx_ms") is not None:
            lines.append(
                f"      ONNX (onnxruntime, 1 thread) {r['onnx_ms']:.4f} ms, streamer/ONNX {r['onnx_speedup']:.2f}; "
                f"{r['onnx_max_abs_N']:.1e} N ({r['onnx_max_rel']:.1e} relative)"
            )
        if r.get("why"):
            lines.append(f"      not measured: {r['why']}")
    return lines
