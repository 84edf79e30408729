"""Fleet speed-up: many recordings calibrated one result per file, with 1 and then 2 joblib workers in one run.

Usage: python perf/bench_fleet.py [--files 8] [--frames 5000] [--jobs 1 2] [--repeats 2]
       [--model capstan-nonsmooth] [--recipe snake12-paper] [--json FILE]

Data: ``--files`` terminal-only recordings of the recipe (one simulator seed each), written as
Parquet files, as a fleet of robots or of days would be.  Each ``--jobs`` setting calibrates the
whole fleet (:func:`tendon_id.report.fleet.calibrate_fleet`, what ``tendon-id calibrate --each``
runs) ``--repeats`` times in this process, the settings taking turns (1, 2, 1, 2, ...) so that a
change of the machine's load weighs on each alike.  The first run with more than one job includes
starting joblib's worker processes (loky's, reused afterwards), so both the first and the best run
are reported.  The speed-up is the best time of the first setting over the best of each other,
measured on one machine in one run.  Whether the cores were free shows in the load average
(``/proc/loadavg``) before and after, and in the cores a run obtained: the CPU time of this process
and its workers over the wall time (with psutil).  Every run must give the same results (wall times
aside).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import tempfile
import time
from pathlib import Path

from tendon_id.atomic import write_json_atomic
from tendon_id.datasets import load_recipe
from tendon_id.report.fleet import calibrate_fleet
from tendon_id.sim import simulate


def loadavg() -> list[float] | None:
    """The 1, 5 and 15 minute load averages, where the system tells them (Linux)."""
    try:
        return [float(x) for x in Path("/proc/loadavg").read_text().split()[:3]]
    except OSError:
        return None


def cpu_seconds() -> float | None:
    """CPU time [s] of this process and its children alive now (joblib's workers), where psutil is installed."""
    try:
        import psutil
    except ImportError:
        return None
    me = psutil.Process()
    total = 0.0
    for p in [me, *me.children(recursive=True)]:
        try:
            t = p.cpu_times()
        except psutil.Error:  # a worker that ended in between
            continue
        total += t.user + t.system
    return total


def timeless(doc: dict) -> str:
    """``doc`` as JSON with its wall times zeroed, to compare two runs."""
    return re.sub(r'"seconds": [0-9.eE+-]+', '"seconds": 0', json.dumps(doc))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--files", type=int, default=8)
    ap.add_argument("--frames", type=int, default=5000)
    ap.add_argument("--jobs", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--model", default="capstan-nonsmooth")
    ap.add_argument("--recipe", default="snake12-paper")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    out: dict = {
        "model": args.model,
        "recipe": args.recipe,
        "files": args.files,
        "frames_per_file": args.frames,
        "cpu_count": os.cpu_count(),
        "machine": platform.machine(),
        "python": platform.python_version(),
        "loadavg_before": loadavg(),
        "runs": [],
    }
    print(f"load average before: {out['loadavg_before']}")
    with tempfile.TemporaryDirectory(prefix="bench-fleet-") as tmp:
        root = Path(tmp)
        recipe = load_recipe(args.recipe)
        paths = []
        for seed in range(args.files):
            path = root / "data" / f"robot{seed:02d}.parquet"
            path.parent.mkdir(exist_ok=True)
            simulate(recipe, "terminal-only", frames=args.frames, seed=seed).recording.write(path)
            paths.append(path)
        first_doc = None
        runs = {jobs: {"n_jobs": jobs, "seconds": [], "cores": [], "fit_s_sum": []} for jobs in args.jobs}
        for r in range(args.repeats):
            for jobs in args.jobs:
                cpu0, t0 = cpu_seconds(), time.perf_counter()
                doc = calibrate_fleet(paths, model=args.model, out=root / f"out-{jobs}-{r}", n_jobs=jobs)
                wall = time.perf_counter() - t0
                cpu = cpu_seconds()
                first_doc = first_doc or doc
                if timeless(doc) != timeless(first_doc):
                    raise SystemExit(f"n_jobs={jobs}: the results differ from the first run's")
                run = runs[jobs]
                run["seconds"].append(wall)
                run["cores"].append(None if cpu is None else (cpu - cpu0) / wall)
                run["fit_s_sum"].append(sum(e["seconds"] for e in doc["entries"]))
                cores = "" if cpu is None else f", {run['cores'][-1]:.2f} cores"
                print(f"round {r + 1}, n_jobs={jobs}: {wall:.1f} s{cores} (the fits {run['fit_s_sum'][-1]:.1f} s)")
        out["runs"] = list(runs.values())
        for run in out["runs"]:
            run["best_s"] = min(run["seconds"])
    base = out["runs"][0]["best_s"]
    for run in out["runs"][1:]:
        run["speedup"] = base / run["best_s"]
        run["speedup_first"] = out["runs"][0]["seconds"][0] / run["seconds"][0]
        print(
            f"speed-up {args.jobs[0]} -> {run['n_jobs']} workers: {run['speedup']:.2f}x best of {args.repeats} "
            f"({run['speedup_first']:.2f}x first runs, worker start-up included); same results: yes"
        )
    out["loadavg_after"] = loadavg()
    print(f"load average after: {out['loadavg_after']} ({os.cpu_count()} cores)")
    if args.json:
        write_json_atomic(args.json, out)


if __name__ == "__main__":
    main()
