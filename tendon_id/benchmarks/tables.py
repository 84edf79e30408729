"""Table I (single passage) and Table II (cascade) of the paper, on simulated data.

The paper's test sets are small (Table II: 800 / 500 / 1260 frames), so one split is a
noisy estimate.  Each benchmark therefore repeats the whole protocol on ``repeats``
random splits by trajectory (seeds ``seed .. seed + repeats - 1``) and reports the mean
of every metric, with its standard deviation over splits under ``"*_sd"`` keys.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

import numpy as np

from tendon_id.benchmarks.splits import TEST_PROTOCOLS, paper_split, score_test
from tendon_id.datasets import load
from tendon_id.progress import progress_bar
from tendon_id.zoo import make
from tendon_id.zoo.guard import guard_fired, quiet_guard, worse_kinds_text

#: Rows of Table I (single passage) and Table II (cascade), in the paper's order.
TABLE1_METHODS = (
    "proximal",
    "capstan-simple",
    "capstan-contact",
    "capstan-nonsmooth",
    "transformer",
    "lstm",
    "mlp",
    "pg-chtc",
)
TABLE2_METHODS = (
    "proximal",
    "capstan-nonsmooth",
    "pg-chtc w/o physics regularizer",
    "pg-chtc w/o temporal residual",
    "pg-chtc",
    "pg-chtc-ns w/o correction",
    "pg-chtc-ns w/o state inputs",
    "pg-chtc-ns",
)
METRIC_KEYS = ("rmse", "r2", "max_error")

#: Table rows that are not plain zoo names: (zoo name, settings).
ROW_MODELS = {
    "pg-chtc w/o physics regularizer": ("pg-chtc", {"physics_reg": False}),
    "pg-chtc w/o temporal residual": ("pg-chtc", {"temporal_residual": False}),
    "pg-chtc-ns w/o correction": ("pg-chtc-ns", {"correction": False}),
    "pg-chtc-ns w/o state inputs": ("pg-chtc-ns", {"state_inputs": False}),
}


def model_factory(preset: str, seed: int = 0) -> Callable:
    """Builds the model of a table row; learned models get the benchmark's preset and seed."""

    def build(method: str):
        name, params = ROW_MODELS.get(method, (method, {}))
        cls = make(name).__class__
        extra = {k: v for k, v in (("preset", preset), ("seed", seed), ("progress", False)) if k in cls.param_names()}
        return make(name, **{**extra, **params})

    return build


def _mean_sd(ms: list[dict | None]) -> tuple[dict | None, dict | None]:
    if not ms or any(m is None for m in ms):
        return None, None
    mean = {k: float(np.mean([m[k] for m in ms])) for k in METRIC_KEYS}
    sd = {k: float(np.std([m[k] for m in ms])) for k in METRIC_KEYS}
    return mean, sd


def _aggregate(per_split: list[list[dict]], repeats: int) -> list[dict]:
    """Average rows with the same (method, protocol) over splits."""
    rows = []
    for k, first in enumerate(per_split[0]):
        group = [split[k] for split in per_split]
        term, term_sd = _mean_sd([g["terminal"] for g in group])
        joints, joints_sd = _mean_sd([g["joints"] for g in group])
        rows.append(
            {
                "method": first["method"],
                "protocol": first["protocol"],
                "terminal": term,
                "joints": joints,
                "terminal_sd": term_sd,
                "joints_sd": joints_sd,
                "repeats": repeats,
            }
        )
    return rows


def _row(method: str, protocol: str, score: dict) -> dict:
    joints = score.get("joints")
    return {
        "method": method,
        "protocol": protocol,
        "terminal": score["terminal"],
        "joints": joints["overall"] if joints else None,
    }


def table1(
    *,
    recipe: str = "snake12-paper",
    preset: str = "fast",
    seed: int = 0,
    repeats: int = 5,
    methods: Sequence[str] = TABLE1_METHODS,
    factory: Callable | None = None,
    progress: bool | None = None,
) -> dict:
    """Single-passage, unit-level test (paper Table I): calibrate on 70 % of trajectories, test on the rest."""
    t0 = time.perf_counter()
    factory = factory or model_factory(preset, seed)
    rec = load(recipe, protocol="single-passage", progress=progress)
    per_split = []
    for s in progress_bar(range(seed, seed + repeats), desc="table1", enable=progress):
        train, test = rec.split((0.7, 0.3), seed=s)
        per_split.append([_row(m, "single-passage", factory(m).fit(train).score(test)) for m in methods])
    return {
        "benchmark": "table1",
        "preset": preset,
        "recipe": recipe,
        "rows": _aggregate(per_split, repeats),
        "seconds": time.perf_counter() - t0,
        "frames": {"train": train.n_frames, "test": test.n_frames},
    }


def table2(
    *,
    recipe: str = "snake12-paper",
    preset: str = "fast",
    seed: int = 0,
    repeats: int = 3,
    methods: Sequence[str] = TABLE2_METHODS,
    factory: Callable | None = None,
    progress: bool | None = None,
) -> dict:
    """Cascade, open-loop logged-data evaluation (paper Table II), per protocol and frame-weighted overall.

    Analytic baselines are calibrated on the training and validation trajectories only and
    tested on held-out trajectories; with simulator truth every row also reports the
    intermediate joints (2..N-1), which the paper could not measure.
    """
    t0 = time.perf_counter()
    factory = factory or model_factory(preset, seed)
    per_split, guards = [], []
    for s in progress_bar(range(seed, seed + repeats), desc="table2", enable=progress):
        split = paper_split(recipe, s, progress=progress)
        rows = []
        for method in progress_bar(methods, desc=f"split {s}", enable=progress):
            with quiet_guard():  # its figures go into the result
                model = factory(method).fit(split.calibration)
            if getattr(model, "guard_", None):
                guards.append({"method": method, "split": s, **model.guard_})
            scored = score_test(model, split.test)
            rows += [_row(method, p, scored["protocols"][p]) for p in TEST_PROTOCOLS]
            rows.append(
                {"method": method, "protocol": "overall", "terminal": scored["terminal"], "joints": scored["joints"]}
            )
        per_split.append(rows)
    return {
        "benchmark": "table2",
        "preset": preset,
        "recipe": recipe,
        "rows": _aggregate(per_split, repeats),
        "guards": guards,
        "seconds": time.perf_counter() - t0,
        "frames": {
            "train": split.train.n_frames,
            "val": split.val.n_frames,
            **{p: split.test[p].n_frames for p in TEST_PROTOCOLS},
        },
    }


def format_rows(result: dict) -> str:
    """Table I / II rows as an aligned text table (terminal and intermediate joints), then where a guard fired."""
    w = max([22] + [len(r["method"]) for r in result["rows"]])
    head = (
        f"{'method':{w}s} {'protocol':15s} {'RMSE [N]':>9s} {'+-sd':>6s} {'R2':>7s} {'MaxErr':>8s} | "
        f"{'joints RMSE':>11s} {'R2':>7s}"
    )
    reps = result["rows"][0].get("repeats", 1) if result["rows"] else 1
    lines = [
        f"{result['benchmark']} ({result.get('recipe', '')}, preset {result['preset']}, mean over {reps} splits, "
        f"{result['seconds']:.1f} s)",
        head,
        "-" * len(head),
    ]
    for r in result["rows"]:
        t, j = r["terminal"], r["joints"]
        sd = (r.get("terminal_sd") or {}).get("rmse", 0.0)
        js = f"{j['rmse']:11.3f} {j['r2']:7.3f}" if j else f"{'-':>11s} {'-':>7s}"
        lines.append(
            f"{r['method']:{w}s} {r['protocol']:15s} {t['rmse']:9.3f} {sd:6.2f} {t['r2']:7.3f} "
            f"{t['max_error']:8.3f} | {js}"
        )
    for g in result.get("guards", []):
        if guard_fired(g):
            where = worse_kinds_text(g)
            lines.append(
                f"guard: {g['method']} (split {g['split']}) was {g['ratio']:.2f}x its prior {g['prior']} on validation"
                + (f"; worse on {where}" if where else "")
            )
    return "\n".join(lines)
