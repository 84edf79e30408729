"""Table I (single passage) and Table II (cascade) of the paper, on simulated data."""

from __future__ import annotations

import time
from collections.abc import Sequence

from tendon_id.benchmarks.splits import TEST_PROTOCOLS, paper_split
from tendon_id.datasets import load
from tendon_id.metrics import frame_weighted
from tendon_id.progress import progress_bar
from tendon_id.zoo import make

#: Physics rows of Table I and the reference rows of Table II (learned rows join with the learners).
TABLE1_METHODS = ("proximal", "capstan-simple", "capstan-contact", "capstan-nonsmooth")
TABLE2_METHODS = ("proximal", "capstan-nonsmooth")


def _row(method: str, protocol: str, score: dict) -> dict:
    joints = score.get("joints")
    return {"method": method, "protocol": protocol, "terminal": score["terminal"], "joints": joints["overall"] if joints else None}


def table1(*, recipe: str = "snake12-paper", preset: str = "fast", seed: int = 0, methods: Sequence[str] = TABLE1_METHODS,
           progress: bool | None = None) -> dict:
    """Single-passage, unit-level test (paper Table I): calibrate on 70 % of trajectories, test on the rest."""
    t0 = time.perf_counter()
    rec = load(recipe, protocol="single-passage", progress=progress)
    train, test = rec.split((0.7, 0.3), seed=seed)
    rows = []
    for method in progress_bar(methods, desc="table1", enable=progress):
        model = make(method).fit(train)
        rows.append(_row(method, "single-passage", model.score(test)))
    return {"benchmark": "table1", "preset": preset, "recipe": recipe, "rows": rows, "seconds": time.perf_counter() - t0,
            "frames": {"train": train.n_frames, "test": test.n_frames}}


def table2(*, recipe: str = "snake12-paper", preset: str = "fast", seed: int = 0, methods: Sequence[str] = TABLE2_METHODS,
           progress: bool | None = None) -> dict:
    """Cascade, open-loop logged-data evaluation (paper Table II), per protocol and frame-weighted overall.

    Analytic baselines are calibrated on the training and validation trajectories only and
    tested on held-out trajectories; with simulator truth every row also reports the
    intermediate joints (2..N-1), which the paper could not measure.
    """
    t0 = time.perf_counter()
    split = paper_split(recipe, seed, progress=progress)
    calib = split.calibration
    rows = []
    for method in progress_bar(methods, desc="table2", enable=progress):
        model = make(method).fit(calib)
        scores = {p: model.score(split.test[p]) for p in TEST_PROTOCOLS}
        frames = [split.test[p].n_frames for p in TEST_PROTOCOLS]
        for p in TEST_PROTOCOLS:
            rows.append(_row(method, p, scores[p]))
        overall = {"method": method, "protocol": "overall", "terminal": frame_weighted([scores[p]["terminal"] for p in TEST_PROTOCOLS], frames)}
        joint_rows = [scores[p]["joints"]["overall"] if scores[p]["joints"] else None for p in TEST_PROTOCOLS]
        overall["joints"] = frame_weighted(joint_rows, frames) if all(joint_rows) else None
        rows.append(overall)
    return {"benchmark": "table2", "preset": preset, "recipe": recipe, "rows": rows, "seconds": time.perf_counter() - t0,
            "frames": {"train": split.train.n_frames, "val": split.val.n_frames, **{p: split.test[p].n_frames for p in TEST_PROTOCOLS}}}
