"""Simulator speed: 10 000 frames of N = 12 with every effect on (issue goal: under 1 s on 2 cores).

Usage: python benchmarks/bench_simulator.py [--frames 10000] [--repeats 5] [--json FILE]

Times ``tendon_id.sim.simulate`` end to end (motion, actuation, transmission, sensors and the
Recording) on the planned-paths protocol, and, in the same run, the transmission against a
naive per-frame Python loop of the same physics as the baseline (ratio reported).
"""

from __future__ import annotations

import argparse
import os
import platform
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=10000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
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
    vec = transmit(theta, act, reset, recipe.robot, recipe.friction, eff, recipe.dt)
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
        f"stick-slip transmission, 1000 frames: vectorised {t_vec * 1e3:.1f} ms vs naive loop {t_naive * 1e3:.1f} ms "
        f"= {t_naive / t_vec:.0f}x (agree: {agree})"
    )
    if args.json:
        write_json_atomic(args.json, out)


if __name__ == "__main__":
    main()
