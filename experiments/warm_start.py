"""Does a warm start help? Table II's held-out trajectories with and without their session's past.

Usage: python experiments/warm_start.py [--recipe snake12-paper] [--repeats 3] [--seed 0]
       [--methods capstan-nonsmooth pg-chtc] [--preset fast] [--json FILE]

Each logged trajectory of ``snake12-paper`` is an excerpt of one continuous session, so it
starts in the stick/slip and lag state the motion before it left (see the recipe card). A
streaming estimator that ran all session long would have seen that motion's inputs, though
no label. This script scores each method on Table II's held-out trajectories twice:

* ``cold``: from each trajectory's first frame, as ``tendon-id benchmark table2`` does;
* ``warm``: run over the whole session up to the trajectory (every earlier frame's actuator
  tensions and joint angles, logged or not, read through the recipe's sensors), scored on the
  same frames.

Beside them, ``truth-warm`` replays the simulator's own transmission over the session: the
error a model of the exact physics and the exact parameters would have with the whole past
and noise-free inputs (and no terminal ``sensor_bias``, should a recipe switch it on).
Models are fitted once per split on its calibration pool (``PaperSplit.calibration``), as
Table II fits them.
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

from tendon_id.atomic import write_json_atomic
from tendon_id.benchmarks.splits import TEST_PROTOCOLS, paper_split
from tendon_id.benchmarks.tables import model_factory
from tendon_id.data import Recording
from tendon_id.datasets import load, load_recipe
from tendon_id.metrics import frame_weighted, tendon_metrics
from tendon_id.sim import simulate

#: Seed of the noise drawn for the unlogged frames (the logged ones keep their recorded values).
UNLOGGED_NOISE_SEED = 12345


def session_recording(name: str, protocol: str) -> tuple[Recording, Recording, np.ndarray, np.ndarray]:
    """The whole session of a recipe's ``protocol`` as one trajectory.

    Returns the logged recording, the session recording, the session row of each logged row,
    and the noise-free terminal tensions [N] of the logged rows from the simulator's own run
    over the session.
    Logged rows carry the recorded (cached) measurements; unlogged rows are read through the
    recipe's sensors from the simulator's true inputs.  Their terminal column is never scored.
    """
    recipe = load_recipe(name)
    sim = simulate(recipe, protocol)
    rec = load(name, protocol=protocol)
    if not np.array_equal(sim.recording.terminal, rec.terminal):
        raise RuntimeError(
            f"the cached {protocol} data of {recipe.name} differ from a fresh simulation; clear the cache"
        )
    ses = sim.session
    rng = np.random.default_rng(UNLOGGED_NOISE_SEED)
    actuator = recipe.sensors.read_tensions(rng, ses.actuator)
    actuator[ses.logged] = rec.actuator
    terminal = np.empty((len(ses.logged), 3))
    terminal[ses.logged] = rec.terminal
    terminal[~ses.logged] = actuator[~ses.logged, -1]  # a positive placeholder: never scored
    whole = Recording.from_arrays(
        trajectory="session",
        t=np.arange(len(ses.logged)) * recipe.dt,
        angles=recipe.sensors.read_angles(ses.theta),
        actuator=actuator,
        terminal=terminal,
        meta=rec.meta,
    )
    return rec, whole, np.flatnonzero(ses.logged), sim.chain[:, -1, -1, :]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--recipe", default="snake12-paper")
    ap.add_argument("--repeats", type=int, default=3, help="Table II splits (seed, seed+1, ...)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--methods", nargs="+", default=["capstan-nonsmooth", "pg-chtc"])
    ap.add_argument("--preset", default="fast", help="size of learned models (fast or paper)")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    t0 = time.perf_counter()
    sessions = {p: session_recording(args.recipe, p) for p in TEST_PROTOCOLS}
    build = model_factory(args.preset, args.seed)
    rows = []
    for s in range(args.seed, args.seed + args.repeats):
        split = paper_split(args.recipe, s)
        frames = [split.test[p].n_frames for p in TEST_PROTOCOLS]
        models = {m: build(m).fit(split.calibration) for m in args.methods}
        scores = {f"{m} {mode}": [] for m in args.methods for mode in ("cold", "warm")} | {"truth-warm": []}
        for p in TEST_PROTOCOLS:
            rec, whole, rows_of, truth = sessions[p]
            held = np.isin(rec.trajectory_ids, split.test[p].trajectories)
            y = rec.terminal[held]
            for m, model in models.items():
                scores[f"{m} cold"].append(tendon_metrics(model.predict_terminal(split.test[p]), y))
                scores[f"{m} warm"].append(tendon_metrics(model.predict_terminal(whole)[rows_of[held]], y))
            scores["truth-warm"].append(tendon_metrics(truth[held], y))
        for name, ms in scores.items():
            rmse = {p: m["rmse"] for p, m in zip(TEST_PROTOCOLS, ms)}
            rmse["overall"] = frame_weighted(ms, frames)["rmse"]
            rows.append({"split": s, "method": name, "rmse": rmse})
        print(f"split {s} done ({time.perf_counter() - t0:.0f} s)", flush=True)
    secs = time.perf_counter() - t0
    names = list(dict.fromkeys(r["method"] for r in rows))
    mean = {n: float(np.mean([r["rmse"]["overall"] for r in rows if r["method"] == n])) for n in names}
    print(f"\n{args.recipe}: terminal RMSE [N] on Table II's held-out trajectories, preset {args.preset}")
    print(f"{'split':>5s} {'method':26s} " + " ".join(f"{p:>13s}" for p in (*TEST_PROTOCOLS, "overall")))
    for r in rows:
        print(
            f"{r['split']:5d} {r['method']:26s} "
            + " ".join(f"{r['rmse'][p]:13.2f}" for p in (*TEST_PROTOCOLS, "overall"))
        )
    print(
        "mean overall: "
        + ", ".join(f"{n} {v:.2f} N" for n, v in mean.items())
        + f"   ({secs:.0f} s, {platform.machine()}, {platform.python_version()})"
    )
    if args.json:
        write_json_atomic(
            args.json,
            {
                "benchmark": "warm_start",
                "recipe": args.recipe,
                "preset": args.preset,
                "rows": rows,
                "mean_overall": mean,
                "seconds": secs,
            },
        )


if __name__ == "__main__":
    main()
