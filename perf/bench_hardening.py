"""Issue 19's speed goals, before and after, in one run: calibration, posterior, identifiability, streaming, simulator.

Usage: python perf/bench_hardening.py --before REV [--json FILE] [--skip KIND ...]

Checks out ``REV`` (the code before the change) in a temporary git worktree and runs every
measurement there and in this tree, one after the other, each in a fresh Python process
(``python -c`` with the tree as its working directory, so that ``import tendon_id`` is that
tree's).  Measured, on the machine it runs on:

``calibration``
    ``capstan-nonsmooth`` fitted on the ``snake12-paper`` calibration pool of split 0 (22 700
    frames): the first fit in the process (compilation included) and the median of three more;
    the fitted law, to compare the optimum.
``posterior``
    :func:`tendon_id.calibration.posterior.sample_posterior` of ``capstan-contact`` on the same pool.
``identifiability``
    :func:`tendon_id.identifiability.analyse` of 4 000 terminal-only frames of ``snake12-paper``.
``streaming``
    The paper preset's native streaming engine (untrained weights: latency does not depend on
    them), N = 12, on 1 and 2 threads (and "auto", and float16 weights, where the tree has them),
    idle and beside a process that keeps one core busy.
``simulator``
    This tree's ``bench_simulator.py --load-check`` with either tree's ``tendon_id``:
    1 000 000 frames of N = 12 with every effect, 20 chunks of 50 000 on 2 joblib workers;
    frames/s, each worker's peak memory, and each chunk's checksum (the sum of its terminal and
    actuator tensions), which must agree before and after to rounding.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

COMMON = """
import json, time, numpy as np
"""

CALIBRATION = """
from tendon_id.benchmarks.splits import paper_split
from tendon_id.zoo.registry import make
calib = paper_split("snake12-paper", 0).calibration
t0 = time.perf_counter(); make("capstan-nonsmooth").fit(calib); first = time.perf_counter() - t0
times = []
for _ in range(3):
    t0 = time.perf_counter(); m = make("capstan-nonsmooth").fit(calib); times.append(time.perf_counter() - t0)
print(json.dumps({"first_s": first, "median_s": float(np.median(times)), "all_s": times,
    "n_eval": m.calibration_["n_eval"], "loss": m.calibration_["loss"], "A": m.A_.tolist(), "B": m.B_.tolist(),
    "frames": calib.n_frames}))
"""

POSTERIOR = """
from tendon_id.benchmarks.splits import paper_split
from tendon_id.calibration.posterior import sample_posterior
from tendon_id.zoo.registry import make
calib = paper_split("snake12-paper", 0).calibration
m = make("capstan-contact").fit(calib)
t0 = time.perf_counter(); post = sample_posterior(m, calib, seed=0, progress=False); wall = time.perf_counter() - t0
mu0 = post.mu0_samples()[:, 0]
print(json.dumps({"seconds": wall, "ess_min": float(post.ess.min()), "rhat_max": float(post.rhat.max()),
    "tau_max": float(post.tau.max()), "draws": int(post.samples.shape[0]),
    "mu0_mean": mu0.mean(0).tolist(), "mu0_sd": mu0.std(0).tolist()}))
"""

IDENTIFIABILITY = """
from tendon_id.datasets import load_recipe
from tendon_id.identifiability import analyse
from tendon_id.sim import simulate
rec = simulate(load_recipe("snake12-paper"), "terminal-only", frames=4000, seed=0).recording
t0 = time.perf_counter(); r = analyse(rec, progress=False); wall = time.perf_counter() - t0
print(json.dumps({"seconds": wall, "frames": rec.n_frames}))
"""

STREAMING = """
import subprocess, sys
from tendon_id.benchmarks.latency import untrained_model


def _stream(stream, angles, actuator):  # median ms per frame after 10, with public calls only (both trees)
    times = []
    for t in range(len(angles)):
        s = time.perf_counter()
        stream.step(angles[t], actuator[t])
        times.append(time.perf_counter() - s)
    return None, float(np.median(times[10:]) * 1e3)
from tendon_id.datasets import load_recipe
from tendon_id.sim import simulate
rec = simulate(load_recipe("snake12-paper"), "planned-paths", frames=320, seed=0).recording
first = rec.select([rec.trajectories[0]])
model = untrained_model(rec, "paper", 0)
default = model.streamer()
AUTO = hasattr(default.engine, "chooser")  # the "auto" thread count exists after the change only
HALF = hasattr(default.engine, "weights")  # so do float16 weights
rows = []
for load in ("idle", "one core busy"):
    proc = subprocess.Popen([sys.executable, "-c", "while True: pass"]) if load != "idle" else None
    try:
        if proc: time.sleep(0.3)
        for weights in ("float32", "float16") if HALF else ("float32",):
            for threads in (1, 2, "auto") if AUTO else (1, 2):
                kw = {"weights": weights} if HALF else {}
                _, ms = _stream(model.streamer("native", threads=threads, **kw), first.angles, first.actuator)
                rows.append({"load": load, "weights": weights, "threads": threads, "ms_median": ms})
    finally:
        if proc: proc.kill(); proc.wait()
print(json.dumps({"default_threads": default.engine.threads, "engine": default.engine_name, "rows": rows}))
"""

# This tree's load check, run in either tree (the script imports that tree's tendon_id): its
# chunks are seeds 0..19, so both runs simulate the same sessions.
SIMULATOR = f"""
import subprocess, sys, tempfile
with tempfile.TemporaryDirectory() as d:
    subprocess.run([sys.executable, {str(ROOT / "benchmarks" / "bench_simulator.py")!r}, "--load-check",
                    "--json", d + "/out.json"], check=True, stdout=subprocess.DEVNULL)
    with open(d + "/out.json") as f:
        out = json.load(f)
print(json.dumps({{"frames": out["total_frames"], "wall_s": out["wall_s"], "frames_per_s": out["frames_per_s"],
    "chunk_s_median": out["chunk_s_median"],
    "peak_rss_mib": {{p: [v["first"], v["last"]] for p, v in out["peak_rss_mib_per_worker"].items()}},
    "checksums": [c["checksum"] for c in out["chunks"]]}}))
"""

MEASUREMENTS = {
    "calibration": CALIBRATION,
    "posterior": POSTERIOR,
    "identifiability": IDENTIFIABILITY,
    "streaming": STREAMING,
    "simulator": SIMULATOR,
}


def run_in(tree: Path, code: str) -> dict:
    """Run ``code`` in a fresh interpreter with ``tree`` as its working directory; its last stdout line is JSON."""
    env = {**os.environ, "PYTHONPATH": str(tree), "TQDM_DISABLE": "1"}
    out = subprocess.run(
        [sys.executable, "-c", COMMON + code], cwd=tree, env=env, capture_output=True, text=True, check=False
    )
    if out.returncode != 0:
        raise RuntimeError(f"measurement failed in {tree}:\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True, help="git revision of the code before the change")
    ap.add_argument("--json", default=None)
    ap.add_argument("--skip", nargs="*", default=[], choices=sorted(MEASUREMENTS))
    args = ap.parse_args()
    results: dict = {"before_rev": args.before, "cpu_count": os.cpu_count()}
    with tempfile.TemporaryDirectory() as tmp:
        before = Path(tmp) / "before"
        subprocess.run(["git", "worktree", "add", "--detach", str(before), args.before], cwd=ROOT, check=True)
        try:
            for name, code in MEASUREMENTS.items():
                if name in args.skip:
                    continue
                results[name] = {"before": run_in(before, code), "after": run_in(ROOT, code)}
                if name == "simulator":
                    b, a = (np.array(results[name][k]["checksums"]) for k in ("before", "after"))
                    results[name]["checksum_max_rel_diff"] = float(np.max(np.abs(a / b - 1.0)))
                print(name, json.dumps(results[name]), flush=True)
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(before)], cwd=ROOT, check=False)
    if args.json:
        from tendon_id.atomic import write_json_atomic

        write_json_atomic(args.json, results)


if __name__ == "__main__":
    main()
