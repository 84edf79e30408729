"""Streaming latency of PG-CHTC (paper Section IV-B reports 23.48 ms per frame on an i9 CPU).

Times ``tendon_id.zoo.stream.PGCHTCStream.step`` frame by frame for an N-module robot with the default engine
(the C kernel where it builds), and in the same run the torch engine and a naive per-frame
implementation: every unit called separately for every set, its causal Transformer
recomputed over the whole window of past unit inputs each time.  The naive step is timed
once its window is full (after ``L (h - 1) + 1`` frames), where it does the work it is
defined by; streaming is timed over the whole trajectory after 10 frames.  In the same run, the
exported steps of pg-chtc and of capstan-nonsmooth (``tendon-id export``, C and ONNX) are timed
beside their streamers (:mod:`tendon_id.benchmarks.export_latency`).

Latency does not depend on the weights' values, so the timed model is built untrained:
random weights, the input normalisation fitted on data, and a non-zero temporal head so
that the residual matters.  How closely two computations of the cascade with float32 units
agree does depend on the weights, since the chain carries each unit's rounding on to the
next.  So agreement with batch inference is measured twice: on the timed model, beside the
distance of batch inference itself from a float64 run, and on a ``fast`` model trained on
``posterior-3`` (about 15 s) over a held-out planned path.
"""

from __future__ import annotations

import contextlib
import copy
import subprocess
import sys
import time

import numpy as np
import torch

from learners.cascade import Cascade, normalised_geometry, normalised_tensions
from learners.correction import CorrectedCascade
from learners.presets import preset as get_preset
from learners.streaming_native import kernel_status
from learners.streaming_pack import WEIGHT_FORMATS
from learners.training import fit_feature_norm
from tendon_id.benchmarks.export_latency import exported_latency, format_exported
from tendon_id.datasets import load_recipe
from tendon_id.geometry import sin_q
from tendon_id.sim import simulate
from tendon_id.zoo.inputs import TransmissionInputs
from tendon_id.zoo.learned import PGCHTC
from tendon_id.zoo.learned_ns import PGCHTCNS
from tendon_id.zoo.registry import make


def untrained_model(recording, preset: str, seed: int = 0) -> PGCHTC:
    """A PG-CHTC model with random weights, ready to predict (for timing)."""
    torch.manual_seed(seed)
    model = PGCHTC(preset=preset, seed=seed, progress=False)
    inp = TransmissionInputs.from_recordings(recording)
    cfg = get_preset(preset).unit
    cascade = Cascade(inp.n_modules - 1, cfg)
    wrap = inp.wrap_at(model.alpha_0_)  # no prior: no routing wrap
    fit_feature_norm(cascade, sin_q(inp.angles), wrap, np.concatenate([inp.actuator.reshape(-1, 3), inp.terminal]))
    with torch.no_grad():
        for u in cascade.units:
            if u.residual is not None:
                torch.nn.init.normal_(u.residual.head.weight, std=0.05)
    model.cascade_ = cascade.eval()
    model.geometry_ = inp.geometry
    model.n_modules_ = inp.n_modules
    model.prior_A_ = model.prior_B_ = np.zeros(3)
    model.history_ = {}
    return model


def untrained_ns_model(recording, preset: str, seed: int = 0) -> PGCHTCNS:
    """A pg-chtc-ns model with random correction weights and its prior calibrated on ``recording`` (for timing)."""
    torch.manual_seed(seed)
    model = PGCHTCNS(preset=preset, seed=seed, progress=False)
    inp = TransmissionInputs.from_recordings(recording)
    cascade = CorrectedCascade(inp.n_modules - 1, model.correction_config())
    model.prior_model_ = make("capstan-nonsmooth", seed=seed).fit(recording)
    wrap = inp.wrap_at(model.alpha_0_)  # the prior's fitted routing wrap
    fit_feature_norm(cascade, sin_q(inp.angles), wrap, np.concatenate([inp.actuator.reshape(-1, 3), inp.terminal]))
    with torch.no_grad():
        for u in cascade.units:
            torch.nn.init.normal_(u.head.weight, std=0.05)
    model.cascade_ = cascade.eval()
    model.geometry_, model.n_modules_, model.dt_ = inp.geometry, inp.n_modules, inp.dt
    model.guard_, model.history_ = {}, {}
    return model


def _naive_step(cascade: Cascade, history: list, sin_q, alpha, log_act) -> torch.Tensor:
    """One frame the obvious way: each (guide, set) unit called alone, its whole window recomputed."""
    n = log_act.shape[0]
    cfg = cascade.cfg
    span = cfg.n_layers * (cfg.window - 1) + 1  # every past frame the output can depend on
    log_t = log_act.to(torch.float64)  # the chain in float64, as in Cascade.forward
    mean, std = cascade.feature_mean, cascade.feature_std
    for g in range(cascade.n_guides):
        unit = cascade.unit(g)
        for j in range(g + 1, n):
            x = torch.cat(
                [normalised_geometry(sin_q[g], alpha[g], mean, std), normalised_tensions(log_t[j], mean, std)]
            )
            history[g][j].append(x)
            del history[g][j][:-span]
            lr = torch.log(unit.backbone(x[None]))[0]
            if unit.residual is not None:
                seq = torch.stack(history[g][j])[None]
                valid = torch.arange(cfg.window)[None, None, :] <= torch.arange(seq.shape[1])[None, :, None]
                lr = lr + torch.log1p(unit.residual(seq, valid)[0, -1])
            log_t[j] = log_t[j] + lr.double()
    return log_t


def _stream(stream, angles: np.ndarray, actuator: np.ndarray) -> tuple[np.ndarray, float]:
    """Estimates of every frame, and the median time per frame after the first 10 [ms]."""
    times, outs = [], []
    for t in range(len(angles)):
        s = time.perf_counter()
        outs.append(stream.step(angles[t], actuator[t]))
        times.append(time.perf_counter() - s)
    return np.stack(outs), float(np.median(times[10:]) * 1e3)


@contextlib.contextmanager
def busy_core():
    """A competing process that keeps one core busy (a pure-Python loop) while the block runs.

    A robot's control computer is never idle; this is the simplest stand-in for the other
    work on it.
    """
    proc = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        time.sleep(0.3)  # let it start and take its core
        yield proc
    finally:
        proc.kill()
        proc.wait()


def thread_load_table(model, angles: np.ndarray, actuator: np.ndarray, default_threads) -> list[dict]:
    """Streaming latency of the native engine on 1, 2 and "auto" threads, with float32 and float16 weights,
    idle and beside a busy core, in one run.

    Returns rows ``{"load": "idle" | "one core busy", "weights", "threads", "ms_median", "default"}``.
    """
    rows = []
    for load in ("idle", "one core busy"):
        with busy_core() if load != "idle" else contextlib.nullcontext():
            for weights in WEIGHT_FORMATS:
                for threads in (1, 2, "auto"):
                    _, ms = _stream(model.streamer("native", threads=threads, weights=weights), angles, actuator)
                    default = threads == default_threads and weights == "float32"
                    rows.append(
                        {"load": load, "weights": weights, "threads": threads, "ms_median": ms, "default": default}
                    )
    return rows


def float64_batch(model: PGCHTC, rec) -> np.ndarray:
    """Batch inference of ``rec`` (one trajectory) in float64: how far float32 rounding alone moves it."""
    cin, _, _ = model.cascade_inputs([rec])
    c64 = copy.deepcopy(model.cascade_).double()
    with torch.no_grad():
        log_t, _ = c64(cin, torch.arange(model.n_modules_))  # the inputs are float64 already
    out = np.exp(log_t[0, : rec.n_frames].numpy())
    out[:, 0] = rec.actuator[:, 0]
    return out


def trained_agreement(recipe: str, seed: int = 0) -> dict:
    """Streaming against batch inference, both engines and float16 weights, for a ``fast`` model trained on
    ``posterior-3``, over a held-out planned path (maximum relative difference); and the RMSE [N] against the
    simulator's joint-side truth of batch inference and of float16 streaming, whose difference is what the
    reduced precision costs in accuracy."""
    r = load_recipe(recipe)
    train = simulate(r, "posterior-3", frames=4000, seed=seed).recording
    test = simulate(r, "planned-paths", frames=320, seed=seed + 1).recording
    model = make("pg-chtc", preset="fast", seed=seed, progress=False).fit(train)
    traj = test.select([test.trajectories[0]])
    batch = model.predict(traj)
    out = {}
    engines = {"default": {}, "torch": {"engine": "torch"}}
    if kernel_status()[0]:
        engines["float16"] = {"weights": "float16"}
    truth = traj.joint_truth
    rmse = lambda est: float(np.sqrt(np.mean((est[:, 1:] - truth[:, 1:]) ** 2)))  # noqa: E731  (set 1 is measured)
    for name, kwargs in engines.items():
        streamed, _ = _stream(model.streamer(**kwargs), traj.angles, traj.actuator)
        out[name] = float(np.max(np.abs(streamed / batch - 1.0)))
        if name == "float16":
            out["float16_rmse_N"] = rmse(streamed)
    out["batch_rmse_N"] = rmse(batch)
    out["batch_vs_float64"] = float(np.max(np.abs(batch / float64_batch(model, traj) - 1.0)))
    return out


def latency(
    *,
    recipe: str = "snake12-paper",
    preset: str = "paper",
    frames: int = 300,
    naive_frames: int = 15,
    seed: int = 0,
    trained: bool = True,
    progress: bool | None = None,
) -> dict:
    """Median per-frame latency of streaming (default and torch engines) against the naive implementation.

    Also reports the agreement of streaming with batch inference.
    """
    t0 = time.perf_counter()
    torch.set_num_threads(max(1, torch.get_num_threads()))
    rec = simulate(load_recipe(recipe), "planned-paths", frames=max(frames, 320), seed=seed).recording
    first = rec.select([rec.trajectories[0]])
    model = untrained_model(rec, preset, seed)
    batch = model.predict(first)
    exact = float64_batch(model, first)
    angles, act = first.angles, first.actuator
    default = model.streamer()
    streamed, stream_ms = _stream(default, angles, act)
    streamed_torch, torch_ms = _stream(model.streamer("torch"), angles, act)
    native_threads = default.engine.threads if default.engine_name == "native" else None
    rel = lambda a, b: float(np.max(np.abs(a / b - 1.0)))  # noqa: E731
    one_ms = same_bits = None
    if native_threads in (2, "auto"):  # the helper thread's gain, measured in the same run
        streamed_one, one_ms = _stream(model.streamer("native", threads=1), angles, act)
        same_bits = bool(np.array_equal(streamed_one, streamed))
    f16_ms = f16_rel = None
    if default.engine_name == "native":  # half-precision weights, default threads
        streamed_f16, f16_ms = _stream(model.streamer(weights="float16"), angles, act)
        f16_rel = rel(streamed_f16, batch)
    load_rows = thread_load_table(model, angles, act, native_threads) if default.engine_name == "native" else []
    ns = untrained_ns_model(rec, preset, seed)
    ns_streamed, ns_ms = _stream(ns.streamer(), angles, act)
    # The exported steps (C, ONNX) of pg-chtc and of the calibrated capstan-nonsmooth, beside their streamers.
    starts = np.arange(first.n_frames) == 0
    exported = exported_latency({"pg-chtc": model, "capstan-nonsmooth": ns.prior_model_}, angles, act, starts)

    n = model.n_modules_
    history = [[[] for _ in range(n)] for _ in range(n - 1)]
    naive_times, naive_out = [], []
    f32 = lambda x: torch.as_tensor(x, dtype=torch.float32)  # noqa: E731
    cfg = model.cascade_.cfg
    # The naive step recomputes every past frame an output depends on; until that history has
    # filled (the first `span` frames) it does less, so only the frames after it are timed.
    span = cfg.n_layers * (cfg.window - 1) + 1 if cfg.temporal_residual else 1
    timed = range(min(span, first.n_frames - 1), min(span + naive_frames, first.n_frames))
    with torch.inference_mode():
        sq, al = sin_q(angles), TransmissionInputs.from_recordings(first, model.geometry_).wrap_at(model.alpha_0_)
        for t in range(timed.stop):
            s = time.perf_counter()
            out = _naive_step(model.cascade_, history, f32(sq[t]), f32(al[t]), f32(np.log(act[t])))
            if t in timed:
                naive_times.append(time.perf_counter() - s)
                naive_out.append(np.exp(out.numpy()))
    naive_ms = float(np.median(naive_times) * 1e3)
    agreement = trained_agreement(recipe, seed) if trained else None
    return {
        "benchmark": "latency",
        "n_modules": n,
        "preset": preset,
        "engine": default.engine_name,
        "streaming_ms_median": stream_ms,
        "naive_ms_median": naive_ms,
        "speedup": naive_ms / stream_ms,
        "max_rel_diff_vs_batch": rel(streamed, batch),
        "torch_streaming_ms_median": torch_ms,
        "speedup_vs_torch": torch_ms / stream_ms,
        "torch_max_rel_diff_vs_batch": rel(streamed_torch, batch),
        "max_rel_diff_vs_float64": rel(streamed, exact),
        "batch_max_rel_diff_vs_float64": rel(batch, exact),
        "naive_max_rel_diff_vs_batch": rel(np.stack(naive_out)[:, 1:], batch[timed.start : timed.stop, 1:]),
        "trained_fast": agreement,
        "ns_streaming_ms_median": ns_ms,
        "ns_vs_pgchtc": ns_ms / stream_ms,
        "ns_max_rel_diff_vs_batch": rel(ns_streamed, ns.predict(first)),
        "native_threads": native_threads,
        "native_one_thread_ms_median": one_ms,
        "native_threads_same_bits": same_bits,
        "float16_ms_median": f16_ms,
        "float16_max_rel_diff_vs_batch": f16_rel,
        "thread_load": load_rows,
        "exported": exported,
        "frames": first.n_frames,
        "naive_frames": len(naive_times),
        "threads": torch.get_num_threads(),
        "rows": [],
        "seconds": time.perf_counter() - t0,
    }


def format_latency(r: dict) -> str:
    threads = f" on {r['native_threads']} threads" if r.get("native_threads") else ""
    lines = [
        f"latency (N = {r['n_modules']}, preset {r['preset']}, {r['threads']} threads, "
        f"median of {r['frames']} frames):",
        f"  streaming, {r['engine']} engine{threads}: {r['streaming_ms_median']:.2f} ms/frame; "
        "max relative difference from batch "
        f"{r['max_rel_diff_vs_batch']:.2e} (from float64 {r['max_rel_diff_vs_float64']:.2e})",
    ]
    if r.get("native_one_thread_ms_median"):
        lines.append(
            f"  streaming, native engine on 1 thread: {r['native_one_thread_ms_median']:.2f} ms/frame "
            f"({r['native_one_thread_ms_median'] / r['streaming_ms_median']:.2f}x slower; "
            f"{'same bits' if r['native_threads_same_bits'] else 'DIFFERENT bits'})"
        )
    if r.get("thread_load"):
        lines.append("  native engine [ms/frame], idle and beside a busy core:")
        for load in ("idle", "one core busy"):
            for weights in WEIGHT_FORMATS:
                cells = ", ".join(
                    f"{row['threads']} thread{'' if row['threads'] == 1 else 's'} {row['ms_median']:.2f}"
                    + (" (default)" if row["default"] else "")
                    for row in r["thread_load"]
                    if row["load"] == load and row.get("weights", "float32") == weights
                )
                lines.append(f"    {load:<13}  {weights} weights: {cells}")
    if r.get("float16_ms_median"):
        lines.append(
            f"  float16 weights, default threads: {r['float16_ms_median']:.2f} ms/frame "
            f"({r['streaming_ms_median'] / r['float16_ms_median']:.2f}x faster than float32); "
            f"max relative difference from float32 batch {r['float16_max_rel_diff_vs_batch']:.2e}"
        )
    if r["engine"] != "torch":
        lines.append(
            f"  streaming, torch engine: {r['torch_streaming_ms_median']:.2f} ms/frame "
            f"({r['speedup_vs_torch']:.1f}x slower); "
            f"max relative difference from batch {r['torch_max_rel_diff_vs_batch']:.2e}"
        )
    lines.append(
        f"  naive per-frame: {r['naive_ms_median']:.1f} ms/frame -> streaming is {r['speedup']:.1f}x faster; "
        f"max relative difference from batch {r['naive_max_rel_diff_vs_batch']:.2e}"
    )
    lines.append(f"  batch inference (float32 units) is {r['batch_max_rel_diff_vs_float64']:.2e} from float64")
    if r.get("ns_streaming_ms_median") is not None:
        lines.append(
            f"  pg-chtc-ns streaming (numpy, same preset's width): {r['ns_streaming_ms_median']:.2f} ms/frame, "
            f"{r['ns_vs_pgchtc']:.2f}x pg-chtc's; max relative difference from batch "
            f"{r['ns_max_rel_diff_vs_batch']:.2e}"
        )
    if r.get("exported"):
        lines += format_exported(r["exported"])
    a = r.get("trained_fast")
    if a:
        lines.append(
            f"  trained fast model, held-out planned path: streaming differs from batch by {a['default']:.2e} "
            f"({r['engine']} engine), "
            f"{a['torch']:.2e} (torch engine); batch is {a['batch_vs_float64']:.2e} from float64"
        )
        if "float16" in a:
            lines.append(
                f"  trained fast model, float16 weights: {a['float16']:.2e} from batch; RMSE against the "
                f"simulator's truth {a['float16_rmse_N']:.3f} N (float32 batch {a['batch_rmse_N']:.3f} N)"
            )
    return "\n".join(lines)
