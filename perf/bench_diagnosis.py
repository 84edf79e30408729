"""Diagnosis speed (goal: one diagnosis of a 5 000-frame recording with every candidate in <= 60 s on 2 cores).

Usage: python perf/bench_diagnosis.py [--frames 5000] [--jobs 1 2] [--recipe snake12-elastic]
       [--base capstan-nonsmooth] [--json FILE]

Data: one recording of the recipe's planned paths (``snake12-elastic``: elastic tendons, the
sensors as built, logs cut from one continuous session).  Against a ``capstan-nonsmooth`` base
(contact and stick/slip in it) every other candidate applies: 13 of them, the elastic tendon and
the start state included.  Without test data the diagnosis cross-validates by trajectory (3
folds).  The same diagnosis is timed with each ``--jobs`` setting, in one run, so the speed-up is
a ratio measured on one machine.  (Before issue 39: ``snake12-paper`` with sensor bias, a
``capstan-simple`` base and 8 candidates.)
"""

from __future__ import annotations

import argparse
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
    ap.add_argument("--recipe", default="snake12-elastic")
    ap.add_argument("--base", default="capstan-nonsmooth")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    rec = simulate(load_recipe(args.recipe), "planned-paths", frames=args.frames, seed=11).recording
    base = zoo.make(args.base).fit(rec)
    out: dict = {
        "recipe": args.recipe,
        "base": args.base,
        "frames": rec.n_frames,
        "cpu_count": os.cpu_count(),
        "machine": platform.machine(),
        "runs": [],
    }
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
