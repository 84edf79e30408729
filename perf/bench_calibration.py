"""Calibration and posterior speed (issue goals: capstan-nonsmooth on 23 000 frames in <= 5 s;
an emcee posterior with ESS >= 1000 for every parameter in <= 60 s; both on 2 cores).

Usage: python perf/bench_calibration.py [--repeats 3] [--json FILE]

Data: the Section IV-B calibration pool of snake12-paper (22 700 frames), and 23 000
terminal-only frames of snake12-noise-only for a well-posed posterior.  In the same run
the nonsmooth objective is timed against a baseline: the play operator as the
textbook per-frame loop.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from tendon_id.atomic import write_json_atomic
from tendon_id.benchmarks.splits import paper_split
from tendon_id.calibration.posterior import sample_posterior
from tendon_id.datasets import load_recipe
from tendon_id.sim import simulate
from tendon_id.zoo.inputs import TransmissionInputs
from tendon_id.zoo.registry import make


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    calib = paper_split("snake12-paper", 0).calibration
    out: dict = {
        "frames_calibration": calib.n_frames,
        "cpu_count": os.cpu_count(),
        "machine": platform.machine(),
        "python": platform.python_version(),
    }

    times = []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        m = make("capstan-nonsmooth").fit(calib)
        times.append(time.perf_counter() - t0)
    out["nonsmooth_fit_s_median"] = float(np.median(times))
    out["nonsmooth_fit_s_all"] = times
    out["nonsmooth_evals"] = m.calibration_["n_eval"]
    out["nonsmooth_mu0"] = m.mu0_[0].tolist()
    print(
        f"capstan-nonsmooth calibration, {calib.n_frames} frames: median {np.median(times):.2f} s over "
        f"{args.repeats} runs ({m.calibration_['n_eval']} evaluations, {m.calibration_['starts']} starts per tendon)"
    )

    # Baseline in the same run: the same objective with the play operator written as the
    # textbook per-frame loop (what a direct implementation of the recursion costs).
    inputs = TransmissionInputs.from_recordings(calib.fitting_view())
    A, B = m.A_[:, :1], m.B_[:, :1]
    t0 = time.perf_counter()
    for _ in range(5):
        ours_pred = m.terminal_reading(inputs, A, B, tendons=np.array([0]))
    t_eval = (time.perf_counter() - t0) / 5
    phi = m.exponent(inputs, A, B)[:, :, 0, 0]  # (T, N-1)
    t0 = time.perf_counter()
    y = np.log(inputs.actuator[:, -1, 0]).copy()
    for g in range(phi.shape[1]):
        x = y.copy()
        for t in range(len(x)):
            lo, hi = x[t] - phi[t, g], x[t] + phi[t, g]
            y[t] = lo if inputs.reset[t] else min(max(y[t - 1], lo), hi)
    t_loop = time.perf_counter() - t0
    agree = bool(np.allclose(np.exp(y), ours_pred[:, 0], rtol=1e-12))
    out.update(
        {
            "objective_eval_s": t_eval,
            "naive_loop_eval_s": t_loop,
            "eval_speedup": t_loop / t_eval,
            "naive_agrees": agree,
        }
    )
    print(
        f"one objective evaluation ({calib.n_frames} frames, 11 guides): {t_eval * 1e3:.1f} ms vectorised vs "
        f"{t_loop * 1e3:.0f} ms per-frame loop = {t_loop / t_eval:.0f}x (agree: {agree}); at "
        f"{m.calibration_['n_eval']} evaluations the loop would take {t_loop * m.calibration_['n_eval']:.0f} s"
    )

    noise_only = simulate(load_recipe("snake12-noise-only"), "terminal-only", frames=23000, seed=0).recording
    for label, data, model in (
        ("noise-only terminal-only, capstan-simple", noise_only, "capstan-simple"),
        ("snake12-paper calibration pool, capstan-contact", calib, "capstan-contact"),
    ):
        fitted = make(model).fit(data)
        post = sample_posterior(fitted, data, seed=0)
        key = "posterior_noise_only" if "noise" in label else "posterior_paper_pool"
        out[key] = {
            "seconds": post.seconds,
            "ess_min": float(post.ess.min()),
            "rhat_max": float(post.rhat.max()),
            "tau_max": float(post.tau.max()),
            "draws": int(post.samples.shape[0]),
        }
        print(
            f"emcee posterior ({label}, {data.n_frames} frames, {len(post.names)} parameters): {post.seconds:.1f} s, "
            f"min ESS {post.ess.min():.0f}, max R-hat {post.rhat.max():.3f}, max tau {post.tau.max():.0f} steps"
        )
    if args.json:
        write_json_atomic(args.json, out)


if __name__ == "__main__":
    main()
