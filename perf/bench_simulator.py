"""Simulator speed: 10 000 frames of N = 12 with every effect on (issue goal: under 1 s on 2 cores).

Usage: python perf/bench_simulator.py [--frames 10000] [--repeats 5] [--json FILE]
       python perf/bench_simulator.py --load-check [--total 1000000] [--chunk 50000] [--jobs 2]

``--load-check`` simulates ``--total`` frames in chunks of ``--chunk`` (each an independent
session of planned paths with every effect, seed = chunk index), ``--jobs`` chunks at a time
in joblib worker processes, keeping only a checksum of each chunk.  It reports frames/s and
every worker's peak resident memory after each chunk: flat memory means the peak after the
last chunk is that after the first.

Times ``tendon_id.sim.simulate`` end to end (motion, actuation, transmission, sensors and the
Recording) on the planned-paths protocol, and, in the same run, the transmission (``transmit``,
compiled where numba is installed) against a naive per-frame Python loop of the same physics as
the baseline (ratio reported).
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import time

import numpy as np

from tendon_id.atomic import write_json_atomic
from tendon_id.datasets import load_recipe
from tendon_id.sim import EFFECT_NAMES, simulate


def naive_stick_slip_chain(log_act: np.ndarray, phi: np.ndarray, reset: np.ndarray) -> np.ndarray:
    """Per-frame, per-guide loop of the nonsmooth capstan: the obvious implementation."""
    n_frames, n = log_act.shape[:2]
    y = np.empty((n_frames, n, n, 3))
    for t in range(n_frames):
        y[t, 0] = log_act[t]
        for g in range(n - 1):
            x = y[t, g, g + 1 :]
            lo, hi = x - phi[t, g, g + 1 :], x + phi[t, g, g + 1 :]
            y[t, g + 1, g + 1 :] = lo if (reset[t] or t == 0) else np.clip(y[t - 1, g + 1, g + 1 :], lo, hi)
    return y


def simulate_chunk(seed: int, frames: int, recipe: str = "snake12-paper") -> dict:
    """One chunk of the load check, in a worker: its frames, time, checksum and the worker's peak memory.

    Every effect is on, with the recipe's settings (``snake12-elastic``: the elastic chain).
    """
    t0 = time.perf_counter()
    res = simulate(load_recipe(recipe), "planned-paths", effects=list(EFFECT_NAMES), frames=frames, seed=seed)
    rec = res.recording
    checksum = float(np.sum(rec.terminal)) + float(np.sum(rec.actuator))  # the data is made, then dropped
    return {
        "seed": seed,
        "frames": rec.n_frames,
        "seconds": time.perf_counter() - t0,
        "checksum": checksum,
        "pid": os.getpid(),
        "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,  # Linux: KiB
    }


def load_check(total: int, chunk: int, jobs: int, recipe: str = "snake12-paper") -> dict:
    """Simulate ``total`` frames in chunks on ``jobs`` worker processes; frames/s and peak memory per worker."""
    from joblib import Parallel, delayed

    n_chunks = -(-total // chunk)
    t0 = time.perf_counter()
    rows = list(
        Parallel(n_jobs=jobs, return_as="generator")(
            delayed(simulate_chunk)(k, min(chunk, total - k * chunk), recipe) for k in range(n_chunks)
        )
    )
    wall = time.perf_counter() - t0
    frames = sum(r["frames"] for r in rows)
    by_worker: dict = {}
    for r in rows:
        by_worker.setdefault(r["pid"], []).append(r["peak_rss_mib"])
    return {
        "recipe": recipe,
        "total_frames": frames,
        "chunk": chunk,
        "jobs": jobs,
        "wall_s": wall,
        "frames_per_s": frames / wall,
        "chunk_s_median": float(np.median([r["seconds"] for r in rows])),
        "peak_rss_mib_per_worker": {
            str(pid): {"first": v[0], "last": v[-1], "chunks": len(v)} for pid, v in by_worker.items()
        },
        "parent_peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "chunks": rows,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=10000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", default=None)
    ap.add_argument("--load-check", action="store_true", help="1e6 frames in chunks: frames/s and peak memory")
    ap.add_argument("--total", type=int, default=1_000_000)
    ap.add_argument("--chunk", type=int, default=50_000)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--recipe", default="snake12-paper", help="recipe whose effect settings apply (load check)")
    args = ap.parse_args()
    if args.load_check:
        out = load_check(args.total, args.chunk, args.jobs, args.recipe)
        mem = out["peak_rss_mib_per_worker"]
        print(
            f"load check ({args.recipe}): {out['total_frames']} frames of N = 12, every effect, "
            f"chunks of {args.chunk} on "
            f"{args.jobs} workers: {out['wall_s']:.1f} s = {out['frames_per_s']:.0f} frames/s "
            f"(one chunk {out['chunk_s_median']:.2f} s); peak memory per worker, first -> last chunk: "
            + ", ".join(f"{v['first']:.0f} -> {v['last']:.0f} MiB ({v['chunks']} chunks)" for v in mem.values())
        )
        if args.json:
            write_json_atomic(args.json, out)
        return
    recipe = load_recipe("snake12-paper")
    simulate(recipe, "planned-paths", effects=list(EFFECT_NAMES), frames=500)  # warm-up (imports, caches)
    times = []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        res = simulate(recipe, "planned-paths", effects=list(EFFECT_NAMES), frames=args.frames, seed=0)
        times.append(time.perf_counter() - t0)
    ours = float(np.median(times))

    # Baseline on the transmission core alone (stick-slip chain), on a 1000-frame slice.
    m = min(1000, args.frames)
    from tendon_id.sim.transmission import transmit

    theta = res.theta_true[:m]
    act = res.chain[:m, 0]
    reset = res.recording.trajectory_starts[:m]
    eff = recipe.effects.with_enabled(["stick_slip"])
    t0 = time.perf_counter()
    vec = transmit(theta, act, reset, recipe.robot, recipe.friction, eff, recipe.dt, with_phi=True)
    t_vec = time.perf_counter() - t0
    phi = np.broadcast_to(vec.phi, (m, recipe.robot.n_modules - 1, recipe.robot.n_modules, 3))
    t0 = time.perf_counter()
    naive = naive_stick_slip_chain(np.log(act), phi, reset)
    t_naive = time.perf_counter() - t0
    n = recipe.robot.n_modules
    iu = np.arange(n)
    agree = np.allclose(np.exp(naive[:, iu, iu]), vec.joint_side, rtol=1e-12)

    out = {
        "frames": args.frames,
        "n_modules": n,
        "effects": list(EFFECT_NAMES),
        "simulate_s_median": ours,
        "simulate_s_all": times,
        "transmission_1000_frames_s": t_vec,
        "naive_loop_1000_frames_s": t_naive,
        "speedup_vs_naive": t_naive / t_vec,
        "naive_agrees": bool(agree),
        "machine": f"{platform.machine()} {platform.processor() or ''}".strip(),
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
    }
    print(
        f"simulate {args.frames} frames, N={n}, every effect on: median {ours:.3f} s over {args.repeats} runs "
        f"(min {min(times):.3f}, max {max(times):.3f}); {os.cpu_count()} cores"
    )
    print(
        f"stick-slip transmission, 1000 frames: transmit {t_vec * 1e3:.1f} ms vs naive loop {t_naive * 1e3:.1f} ms "
        f"= {t_naive / t_vec:.0f}x (agree: {agree})"
    )
    if args.json:
        write_json_atomic(args.json, out)


if __name__ == "__main__":
    main()
