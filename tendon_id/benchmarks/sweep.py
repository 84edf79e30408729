"""One-at-a-time sensitivity sweep of PG-CHTC (the paper's Section IV-B).

The paper selects its operating point ``lambda = 1.0``, ``lambda_s = 0.1``, ``eta_w = 2.0``,
``h = 20`` on the validation split, then varies one setting at a time over
``lambda in [0.03, 30]``, ``lambda_s in [0.003, 3]``, ``eta_w in [0.25, 16]`` and
``h in [5, 80]`` and reports the worst-to-best validation RMSE ratio of each
(1.18, 1.22, 1.30 and 1.12).

Protocol
--------
- Data: the Section IV-B split of a recipe (:func:`~tendon_id.benchmarks.splits.paper_split`):
  ``train`` (70 %) and ``val`` (30 %) of the mixed terminal-only / posterior-3 / posterior-6
  pool, and held-out ``test`` trajectories per protocol.
- Grids: ``points`` log-spaced values between each range's ends (the window rounded to whole
  frames); the value closest to the operating point (in log scale) is replaced by it, or,
  when that value is an end of the range (``points = 2``), the operating point is added.
  Odd ``points`` thus put the operating point in the middle: ``points = 5`` gives
  ``h in {5, 10, 20, 40, 80}`` and ``eta_w in {0.25, 0.71, 2, 5.7, 16}``.
- Each configuration is trained on ``split.train`` **only** (not ``split.calibration``): the
  model still holds out 30 % of those trajectories internally for early stopping.  Training on
  train + val would let the selection metric see its own validation data, so it would no
  longer be a validation score.
- Selection metric (the paper's): the terminal RMSE [N] of that model on ``split.val``, the same
  number as ``model.score(split.val)["terminal"]["rmse"]``.  ``ratios`` are worst / best of it
  over each parameter's grid.
- Held-out metric, side by side: the same model's terminal metrics on ``split.test``, overall
  (frame-weighted over the three test protocols, :func:`~tendon_id.metrics.frame_weighted`),
  and, with simulator truth, the intermediate joints; ``test_ratios`` are worst / best of the
  test RMSE.
- The operating point belongs to every parameter's grid but is trained once; its result is
  repeated in each parameter's rows.

Parallelism
-----------
Configurations are independent jobs run through :class:`joblib.Parallel` with the given
``backend`` and ``n_jobs``.  Each job is the top-level function :func:`sweep_job`, which takes
only plain values (recipe name, seed, preset, parameter name and value), builds its own split
and model and returns a plain dict, so it pickles to any worker, including a remote one
(``backend="dask"`` or ``"ray"`` once registered with joblib; ``backend=None`` uses whatever
:func:`joblib.parallel_config` is active).  The default ``n_jobs = 1`` runs the jobs in turn in
this process: on 2 cores one training run already uses both.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np
from joblib import delayed

from tendon_id.benchmarks.jobs import job_runner
from tendon_id.benchmarks.splits import TEST_PROTOCOLS, paper_split
from tendon_id.checks import check_choice, check_count
from tendon_id.errors import ConfigError
from tendon_id.metrics import frame_weighted, tendon_metrics
from tendon_id.progress import progress_bar
from tendon_id.zoo.registry import make

#: The operating point selected in the paper (Section IV-B); ``window`` is ``h`` [frames].
OPERATING_POINT = {"lam": 1.0, "lam_s": 0.1, "eta_w": 2.0, "window": 20}
#: The sweep ranges of Section IV-B.
RANGES = {"lam": (0.03, 30.0), "lam_s": (0.003, 3.0), "eta_w": (0.25, 16.0), "window": (5, 80)}
#: Worst-to-best validation RMSE ratios the paper reports.
PAPER_RATIOS = {"lam": 1.18, "lam_s": 1.22, "eta_w": 1.30, "window": 1.12}
#: How the table prints each parameter.
LABELS = {"lam": "lambda", "lam_s": "lambda_s", "eta_w": "eta_w", "window": "h"}


def grid(parameter: str, points: int = 5) -> list:
    """The sweep values of one parameter: log-spaced over its range, including the operating point.

    Parameters
    ----------
    parameter : {"lam", "lam_s", "eta_w", "window"}
    points : int
        Number of log-spaced values (at least 2).

    Returns
    -------
    list
        Sorted, distinct values (ints for ``window``).
    """
    if parameter not in RANGES:
        check_choice("parameter", parameter, RANGES, what="sweep parameter")
    check_count("points", points, 2)
    lo, hi = RANGES[parameter]
    op = OPERATING_POINT[parameter]
    values = list(np.geomspace(lo, hi, int(points)))
    near = int(np.argmin([abs(math.log(v / op)) for v in values]))
    if 0 < near < len(values) - 1:
        values[near] = op
    else:
        values.append(op)
    if parameter == "window":
        return sorted({int(round(v)) for v in values})
    return sorted({float(f"{v:.4g}") for v in values})


def _settings(parameter: str, value) -> dict:
    if parameter not in OPERATING_POINT:
        check_choice("parameter", parameter, OPERATING_POINT, what="sweep parameter")
    settings = dict(OPERATING_POINT)
    settings[parameter] = int(value) if parameter == "window" else float(value)
    return settings


def _score_test(model, rec) -> tuple[dict, dict | None]:
    """Terminal and intermediate-joint metrics from one prediction pass (as ``model.score``)."""
    pred = model.predict(rec)
    terminal = tendon_metrics(pred[:, -1], rec.terminal)
    truth, n = rec.joint_truth, pred.shape[1]
    if truth is None or n <= 2:
        return terminal, None
    inner = slice(1, n - 1)
    return terminal, tendon_metrics(
        pred[:, inner].reshape(-1, pred.shape[2]), truth[:, inner].reshape(-1, pred.shape[2])
    )


def sweep_job(recipe: str, seed: int, preset: str, parameter: str, value) -> dict:
    """Train and score one sweep configuration; picklable, plain values in and out.

    The operating point with ``parameter`` set to ``value``: fitted on the split's ``train``
    trajectories, scored on ``val`` (selection) and on the held-out ``test`` trajectories.

    Returns
    -------
    dict
        ``{"settings", "validation": M, "terminal": M (test, frame-weighted), "joints": M | None,
        "test": {protocol: M}, "frames": {protocol: int}, "seconds"}``.
    """
    t0 = time.perf_counter()
    settings = _settings(parameter, value)
    split = paper_split(recipe, seed, progress=False)
    model = make("pg-chtc", preset=preset, seed=seed, progress=False, **settings).fit(split.train)
    validation = tendon_metrics(model.predict_terminal(split.val), split.val.terminal)
    test, joints, frames = {}, {}, {}
    for p in TEST_PROTOCOLS:
        test[p], joints[p] = _score_test(model, split.test[p])
        frames[p] = split.test[p].n_frames
    w = [frames[p] for p in TEST_PROTOCOLS]
    return {
        "settings": settings,
        "validation": validation,
        "terminal": frame_weighted([test[p] for p in TEST_PROTOCOLS], w),
        "joints": frame_weighted([joints[p] for p in TEST_PROTOCOLS], w) if all(joints.values()) else None,
        "test": test,
        "frames": frames,
        "seconds": time.perf_counter() - t0,
    }


def _ratio(values: Sequence[float]) -> float:
    best = min(values)
    return float(max(values) / best) if best > 0 else float("inf")


def sweep(
    *,
    recipe: str = "snake12-paper",
    preset: str = "fast",
    seed: int = 0,
    points: int = 5,
    params: Sequence[str] = ("lam", "lam_s", "eta_w", "window"),
    backend: str | None = "loky",
    n_jobs: int = 1,
    progress: bool | None = None,
) -> dict:
    """The one-at-a-time sensitivity sweep of Section IV-B (see the module docstring).

    Parameters
    ----------
    recipe : str
        Recipe whose :func:`~tendon_id.benchmarks.splits.paper_split` is used.
    preset : str
        PG-CHTC size and schedule (``fast``, ``paper``, ``tiny``).
    seed : int
        Seed of the split and of every model.
    points : int
        Grid size per parameter (log-spaced, operating point included).
    params : sequence of str
        Which of ``lam``, ``lam_s``, ``eta_w``, ``window`` (``h``) to sweep.
    backend : str or None
        joblib backend (``"loky"``, ``"threading"``, a registered ``"dask"`` / ``"ray"``...);
        None: the one :func:`joblib.parallel_config` sets.
    n_jobs : int
        Parallel jobs (joblib's meaning: -1 is all cores).
    progress : bool, optional
        Progress bar over finished jobs (default: on a terminal).

    Returns
    -------
    dict
        The benchmark JSON of :doc:`/cli`: ``{"benchmark": "sweep", "preset", "recipe", "rows":
        [{"method": "pg-chtc", "protocol": "overall", "parameter", "value", "terminal": M,
        "validation_rmse", "joints": M | None, ...}], "ratios": {parameter: worst / best
        validation RMSE}, "test_ratios", "paper_ratios", "operating_point", "grids", "seconds"}``.
    """
    t0 = time.perf_counter()
    params = tuple(params)
    if not params:
        raise ConfigError("the sweep needs at least one parameter")
    grids = {p: grid(p, points) for p in params}
    parallel = job_runner(backend, n_jobs)
    # Build (or read) the split once here, so local workers find it cached and never race to build it.
    split = paper_split(recipe, seed, progress=progress)

    jobs: dict[tuple, tuple[str, object]] = {}  # distinct settings -> (parameter, value) of its first row
    for p in params:
        for v in grids[p]:
            jobs.setdefault(tuple(sorted(_settings(p, v).items())), (p, v))
    keys = list(jobs)
    out = parallel(delayed(sweep_job)(recipe, seed, preset, p, v) for p, v in jobs.values())
    results = dict(zip(keys, progress_bar(out, desc="sweep", total=len(keys), enable=progress)))

    rows, ratios, test_ratios = [], {}, {}
    for p in params:
        group = []
        for v in grids[p]:
            res = results[tuple(sorted(_settings(p, v).items()))]
            group.append(res)
            rows.append(
                {
                    "method": "pg-chtc",
                    "protocol": "overall",
                    "parameter": p,
                    "value": v,
                    "terminal": res["terminal"],
                    "validation_rmse": res["validation"]["rmse"],
                    "validation": res["validation"],
                    "joints": res["joints"],
                    "test": res["test"],
                    "settings": res["settings"],
                    "operating_point": v == OPERATING_POINT[p],
                    "seconds": res["seconds"],
                }
            )
        ratios[p] = _ratio([g["validation"]["rmse"] for g in group])
        test_ratios[p] = _ratio([g["terminal"]["rmse"] for g in group])
    return {
        "benchmark": "sweep",
        "preset": preset,
        "recipe": recipe,
        "seed": seed,
        "rows": rows,
        "ratios": ratios,
        "test_ratios": test_ratios,
        "paper_ratios": {p: PAPER_RATIOS[p] for p in params},
        "operating_point": dict(OPERATING_POINT),
        "grids": grids,
        "points": int(points),
        "backend": backend,
        "n_jobs": int(n_jobs),
        "trained": len(keys),
        "frames": {
            "train": split.train.n_frames,
            "val": split.val.n_frames,
            **{p: split.test[p].n_frames for p in TEST_PROTOCOLS},
        },
        "seconds": time.perf_counter() - t0,
    }


def _fmt_value(v) -> str:
    return f"{v:d}" if isinstance(v, (int, np.integer)) else f"{v:.4g}"


def format_sweep(result: dict) -> str:
    """The sweep as an aligned text table, then the worst-to-best ratios next to the paper's."""
    head = (
        f"{'parameter':10s} {'value':>8s}  {'val RMSE':>9s} | "
        f"{'test RMSE':>9s} {'R2':>7s} {'MaxErr':>8s} | {'joints RMSE':>11s}"
    )
    lines = [
        f"sweep ({result.get('recipe', '')}, preset {result['preset']}, "
        f"{result.get('trained', len(result['rows']))} models "
        f"trained on train, selected on val, tested on held-out test; {result['seconds']:.1f} s)",
        head,
        "-" * len(head),
    ]
    for r in result["rows"]:
        t, j = r["terminal"], r["joints"]
        mark = "*" if r.get("operating_point") else " "
        js = f"{j['rmse']:11.3f}" if j else f"{'-':>11s}"
        lines.append(
            f"{LABELS.get(r['parameter'], r['parameter']):10s} {_fmt_value(r['value']):>8s}{mark} "
            f"{r['validation_rmse']:9.3f} | "
            f"{t['rmse']:9.3f} {t['r2']:7.3f} {t['max_error']:8.3f} | {js}"
        )
    lines.append("* operating point")
    lines.append("")
    lines.append(f"{'worst/best':10s} {'val':>8s} {'test':>8s} {'paper':>8s}")
    for p, ratio in result["ratios"].items():
        test = result.get("test_ratios", {}).get(p)
        paper = result.get("paper_ratios", {}).get(p)
        lines.append(
            f"{LABELS.get(p, p):10s} {ratio:8.3f} {test if test is not None else float('nan'):8.3f} "
            f"{paper if paper is not None else float('nan'):8.2f}"
        )
    return "\n".join(lines)
