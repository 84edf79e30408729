"""Diagnosis speed (issue 15 goal: one diagnosis of a 5 000-frame recording with all 8 candidates in
<= 60 s on 2 cores).

Usage: python perf/bench_diagnosis.py [--frames 5000] [--jobs 1 2] [--json FILE]

Data: one recording of snake12-paper's planned paths with fresh sessions, sensor bias
switched on beside the recipe's effects.  All 8 candidates apply to a ``capstan-simple``
base (the nonsmooth one already holds contact and stick/slip); without test data the
diagnosis cross-validates by trajectory (3 folds).  The same diagnosis is timed with each
``--jobs`` setting, in one run, so the speed-up is a ratio measured on one machine.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import time

from tendon_id import zoo
from tendon_id.atomic import write_json_atomic
from tendon_id.datasets import load_recipe
from tendon_id.diagnosis import diagnose
from tendon_id.sim import simulate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=5000)
    ap.add_argument("--jobs", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    recipe = dataclasses.replace(load_recipe("snake12-paper"), session="fresh")
    effects = recipe.effects.enabled + ("sensor_bias",)
    rec = simulate(recipe, "planned-paths", frames=args.frames, effects=",".join(effects), seed=11).recording
    base = zoo.make("capstan-simple").fit(rec)
    out: dict = {"frames": rec.n_frames, "cpu_count": os.cpu_count(), "machine": platform.machine(), "runs": []}
    for jobs in args.jobs:
        t0 = time.perf_counter()
        result = diagnose(base, rec, n_jobs=jobs, progress=False)
        seconds = time.perf_counter() - t0
        out["runs"].append(
            {
                "n_jobs": jobs,
                "seconds": seconds,
                "candidates": len(result.candidates),
                "verdict": result.verdict.text,
                "ladder": [r.effects[-1] for r in result.ladder],
            }
        )
        print(f"n_jobs={jobs}: {seconds:.1f} s, {len(result.candidates)} candidates; {result.verdict.text}")
    if len(out["runs"]) > 1:
        print(f"speed-up of n_jobs={args.jobs[-1]} over {args.jobs[0]}: {out['runs'][0]['seconds'] / seconds:.2f}x")
    if args.json:
        write_json_atomic(args.json, out)


if __name__ == "__main__":
    main()
