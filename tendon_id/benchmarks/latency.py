"""Streaming latency of PG-CHTC (paper Section IV-B reports 23.48 ms per frame on an i9 CPU).

Times ``PGCHTCStream.step`` frame by frame for an N-module robot, and in the same run a
naive per-frame implementation: every unit called separately for every set, its causal
Transformer recomputed over the whole window of past unit inputs each time.  The naive
step is timed once its window is full (after ``L (h - 1) + 1`` frames), where it does the
work it is defined by; streaming is timed over the whole trajectory after 10 frames.  Latency does
not depend on the weights' values, so the model is built untrained (random weights, with
the input normalisation fitted on data and a non-zero temporal head so that the residual
matters); the agreement of streaming with batch inference is measured on the same model.
"""

from __future__ import annotations

import time

import numpy as np
import torch

from learners.cascade import Cascade
from learners.presets import preset as get_preset
from learners.training import fit_feature_norm
from tendon_id.datasets import load_recipe
from tendon_id.sim import simulate
from tendon_id.zoo.inputs import TransmissionInputs
from tendon_id.zoo.learned import PGCHTC, _sin_q


def untrained_model(recording, preset: str, seed: int = 0) -> PGCHTC:
    """A PG-CHTC model with random weights, ready to predict (for timing)."""
    torch.manual_seed(seed)
    model = PGCHTC(preset=preset, seed=seed, progress=False)
    inp = TransmissionInputs.from_recordings(recording)
    cfg = get_preset(preset).unit
    cascade = Cascade(inp.n_modules - 1, cfg)
    fit_feature_norm(cascade, _sin_q(inp.angles), inp.wrap, np.concatenate([inp.actuator.reshape(-1, 3), inp.terminal]))
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


def _naive_step(cascade: Cascade, history: list, sin_q, alpha, log_act) -> torch.Tensor:
    """One frame the obvious way: each (guide, set) unit called alone, its whole window recomputed."""
    n = log_act.shape[0]
    cfg = cascade.cfg
    span = cfg.n_layers * (cfg.window - 1) + 1  # every past frame the output can depend on
    log_t = log_act.clone()
    for g in range(cascade.n_guides):
        unit = cascade.unit(g)
        for j in range(g + 1, n):
            x = torch.cat([sin_q[g], torch.cos(alpha[g])[None], torch.exp(log_t[j])])
            x = (x - cascade.feature_mean) / cascade.feature_std
            history[g][j].append(x)
            del history[g][j][:-span]
            lr = torch.log(unit.backbone(x[None]))[0]
            if unit.residual is not None:
                seq = torch.stack(history[g][j])[None]
                valid = torch.arange(cfg.window)[None, None, :] <= torch.arange(seq.shape[1])[None, :, None]
                lr = lr + torch.log1p(unit.residual(seq, valid)[0, -1])
            log_t[j] = log_t[j] + lr
    return log_t


def latency(*, recipe: str = "snake12-paper", preset: str = "paper", frames: int = 300, naive_frames: int = 15,
            seed: int = 0, progress: bool | None = None) -> dict:
    """Median per-frame latency of streaming against the naive implementation, and agreement with batch."""
    t0 = time.perf_counter()
    torch.set_num_threads(max(1, torch.get_num_threads()))
    rec = simulate(load_recipe(recipe), "planned-paths", frames=max(frames, 320), seed=seed).recording
    first = rec.select([rec.trajectories[0]])
    model = untrained_model(rec, preset, seed)
    batch = model.predict(first)
    stream = model.streamer()
    angles, act = first.angles, first.actuator
    times, outs = [], []
    for t in range(first.n_frames):
        s = time.perf_counter()
        outs.append(stream.step(angles[t], act[t]))
        times.append(time.perf_counter() - s)
    streamed = np.stack(outs)
    rel = float(np.max(np.abs(streamed / batch - 1.0)))
    stream_ms = float(np.median(times[10:]) * 1e3)

    n = model.n_modules_
    history = [[[] for _ in range(n)] for _ in range(n - 1)]
    naive_times = []
    f32 = lambda x: torch.as_tensor(x, dtype=torch.float32)  # noqa: E731
    cfg = model.cascade_.cfg
    # The naive step recomputes every past frame an output depends on; until that history has
    # filled (the first `span` frames) it does less, so only the frames after it are timed.
    span = cfg.n_layers * (cfg.window - 1) + 1 if cfg.temporal_residual else 1
    timed = range(min(span, first.n_frames - 1), min(span + naive_frames, first.n_frames))
    with torch.inference_mode():
        sq, al = _sin_q(angles), TransmissionInputs.from_recordings(first, model.geometry_).wrap
        for t in range(timed.stop):
            s = time.perf_counter()
            _naive_step(model.cascade_, history, f32(sq[t]), f32(al[t]), f32(np.log(act[t])))
            if t in timed:
                naive_times.append(time.perf_counter() - s)
    naive_ms = float(np.median(naive_times) * 1e3)
    return {"benchmark": "latency", "n_modules": n, "preset": preset, "streaming_ms_median": stream_ms, "naive_ms_median": naive_ms,
            "speedup": naive_ms / stream_ms, "max_rel_diff_vs_batch": rel, "frames": first.n_frames, "naive_frames": len(naive_times),
            "threads": torch.get_num_threads(), "rows": [], "seconds": time.perf_counter() - t0}


def format_latency(r: dict) -> str:
    return (f"latency (N = {r['n_modules']}, preset {r['preset']}, {r['threads']} threads): streaming {r['streaming_ms_median']:.2f} ms/frame "
            f"(median of {r['frames']} frames), naive {r['naive_ms_median']:.1f} ms/frame -> {r['speedup']:.1f}x; "
            f"max relative difference from batch inference {r['max_rel_diff_vs_batch']:.2e}")
