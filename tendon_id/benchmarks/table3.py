"""Table III of the paper: the estimator in a 10 Hz closed loop, on the simulated robot (:doc:`/guide/closed_loop`).

Each estimator is fitted once on the paper's training pool (split ``seed``; never on a
closed-loop run), then drives its own robot through the step-and-return tests of
:data:`~tendon_id.closed_loop.STEP_TESTS` with the controller gains tuned for the oracle.
``repeats`` seeds vary the step direction and the sensor noise; the table reports the mean and
standard deviation over them.  Besides the metrics, the result says why an ordering is what it
is: each estimator's joint-side error during the runs and the slip states it met.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from tendon_id.benchmarks.jobs import job_runner
from tendon_id.benchmarks.splits import paper_split
from tendon_id.benchmarks.tables import model_factory
from tendon_id.checks import check_choices, check_count
from tendon_id.closed_loop import ORACLE, STEP_TESTS, in_loop, joint_torque, loop_metrics, run_step_test, step_test
from tendon_id.closed_loop.statics import crossing_jacobian, on_path, tendon_moments
from tendon_id.datasets import load_recipe
from tendon_id.geometry import tendon_azimuths
from tendon_id.progress import progress_bar
from tendon_id.zoo.guard import guard_fired, quiet_guard, worse_kinds_text

__all__ = ["PAPER_TABLE3", "TABLE3_ESTIMATORS", "format_table3", "table3"]

#: Rows in the paper's order, plus the stateful cascade and the oracle.
TABLE3_ESTIMATORS = ("pg-chtc", "capstan-nonsmooth", "pg-chtc-ns", "proximal", ORACLE)
METRICS = ("rise_s", "settle_s", "rms_deg")
#: The paper's Table III (rise [s], settle [s], RMS [deg]) per regime, estimator and loop.
PAPER_TABLE3 = {
    ("posterior-3", "pg-chtc", 1): (1.86, 2.50, 0.19),
    ("posterior-3", "pg-chtc", 2): (1.78, 2.50, 0.21),
    ("posterior-3", "capstan-nonsmooth", 1): (3.28, 4.50, 0.68),
    ("posterior-3", "capstan-nonsmooth", 2): (2.01, 3.10, 0.29),
    ("posterior-6", "pg-chtc", 1): (2.21, 3.10, 0.72),
    ("posterior-6", "pg-chtc", 2): (2.84, 3.90, 0.83),
    ("posterior-6", "capstan-nonsmooth", 1): (5.14, 6.30, 1.01),
    ("posterior-6", "capstan-nonsmooth", 2): (6.45, 8.00, 1.03),
}


def _diagnostics(run, b: int, loop: int, recipe) -> dict:
    """Why a loop went as it did: the estimate's error at the stepped joints, and their slip states."""
    psi, hole_radius = tendon_azimuths(recipe.robot), recipe.robot.hole_radius
    axes = slice(0, recipe.robot.bending_axes)  # a hinge's bearing takes the moment about its other axis
    win = run.loop_window(loop)
    idx = np.asarray(run.test.joints) - 1
    err = run.estimate[b][win][:, idx] - run.joint_side[b][win][:, idx]
    # What the outer loop feels: the joint torque the estimate implies, against the true one.
    torque_err = joint_torque(err, psi[idx], hole_radius)[..., axes]
    sig = run.sigma[b][win][:, :, idx]  # (F, guides, stepped sets, n tendons)
    on = np.arange(sig.shape[1])[:, None] < idx[None, :]  # guides each stepped set passes
    states = sig[:, on]  # (F, passages, n tendons)
    move = run.t[win] - run.t[win][0] < run.test.move_s(recipe.v_max_deg_s) + 0.5  # the move, then hold
    # The intermediate joints: every set's tension at each joint it passes through on its way to its
    # own (k < j), the estimates terminal-only supervision never sees and the controller feeds forward.
    passing = on_path(psi.shape[0]) & ~np.eye(psi.shape[0], dtype=bool)
    chain_err = np.where(passing[:, :, None], np.nan_to_num(run.chain_estimate[b][win]) - run.chain[b][win], 0.0)
    load_err = tendon_moments(chain_err, crossing_jacobian(run.angles[b][win], recipe.robot))[..., axes]  # (F, N, m)
    return {
        "intermediate_rmse_n": float(np.sqrt(np.mean(chain_err[:, passing] ** 2))),
        "load_error_nm": float(np.sqrt(np.mean(np.sum(load_err**2, axis=-1)))),
        "estimate_rmse_n": float(np.sqrt(np.mean(err**2))),
        "estimate_bias_n": float(np.mean(err)),
        "torque_error_nm": float(np.sqrt(np.mean(np.sum(torque_err**2, axis=-1)))),
        "stick_fraction": float(np.mean(states == 0)),
        "reverse_fraction": float(np.mean(states == -1)),
        "stick_fraction_hold": float(np.mean(states[~move] == 0)),
    }


def table3_job(recipe_name: str, models: dict, regime: str, seed: int) -> tuple[list[dict], dict]:
    """One regime and seed with every estimator in the loop: rows per estimator and loop, and the traces.

    The regime steps the robot's last 3 or 6 joints (:func:`~tendon_id.closed_loop.step_test`): on the
    paper's 12 modules, :data:`~tendon_id.closed_loop.STEP_TESTS` itself.
    """
    recipe = load_recipe(recipe_name)
    estimators = [in_loop(name, models.get(name), recipe.dt) for name in models]
    run = run_step_test(recipe, estimators, step_test(regime, recipe.robot.n_modules), seed=seed)
    rows = []
    for b, name in enumerate(run.estimators):
        for loop in (1, 2):
            rows.append(
                {
                    "regime": regime,
                    "estimator": name,
                    "loop": loop,
                    "seed": seed,
                    **loop_metrics(run, b, loop),
                    "why": _diagnostics(run, b, loop, recipe),
                }
            )
    return rows, run.traces()


def _aggregate(runs: list[dict]) -> list[dict]:
    keys = list(dict.fromkeys((r["regime"], r["estimator"], r["loop"]) for r in runs))
    rows = []
    for regime, est, loop in keys:
        group = [r for r in runs if (r["regime"], r["estimator"], r["loop"]) == (regime, est, loop)]
        row = {"regime": regime, "estimator": est, "loop": loop, "seeds": len(group)}
        for m in METRICS:
            vals = [g[m] for g in group]
            ok = [v for v in vals if v is not None]
            row[m] = float(np.mean(ok)) if len(ok) == len(vals) else None  # null: a seed never settled
            row[f"{m}_sd"] = float(np.std(ok)) if len(ok) == len(vals) else None
            row[f"{m}_reached"] = len(ok)
        row["why"] = {k: float(np.mean([g["why"][k] for g in group])) for k in group[0]["why"]}
        paper = PAPER_TABLE3.get((regime, est, loop))
        row["paper"] = dict(zip(METRICS, paper)) if paper else None
        rows.append(row)
    return rows


def closed_loop_tests(
    recipe: str,
    models: dict,
    seeds: Sequence[int],
    regimes: Sequence[str] = tuple(STEP_TESTS),
    *,
    backend: str | None = "loky",
    n_jobs: int = 1,
    progress: bool | None = None,
) -> dict:
    """Run fitted ``models`` (name to model; None for the oracle) through the step tests.

    Returns ``{"rows": aggregated over seeds, "runs": one row per seed, "traces": the first seed's
    runs per regime}``: the part of Table III's result that the demo shares.
    """
    from joblib import delayed

    seeds = list(seeds)
    jobs = [(regime, s) for regime in regimes for s in seeds]
    runner = job_runner(backend, n_jobs)
    calls = (delayed(table3_job)(recipe, models, regime, s) for regime, s in jobs)
    out = list(progress_bar(runner(calls), desc="closed loop", enable=progress, total=len(jobs)))
    runs = [row for rows, _ in out for row in rows]
    traces = {regime: trace for (regime, s), (_, trace) in zip(jobs, out) if s == seeds[0]}
    return {"rows": _aggregate(runs), "runs": runs, "traces": traces, "repeats": len(seeds)}


def table3(
    *,
    recipe: str = "snake12-paper",
    preset: str = "fast",
    seed: int = 0,
    repeats: int = 3,
    estimators: Sequence[str] = TABLE3_ESTIMATORS,
    backend: str | None = "loky",
    n_jobs: int = 1,
    progress: bool | None = None,
) -> dict:
    """Closed-loop step tests (paper Table III), mean and sd over ``repeats`` seeds.

    Returns the ``--json`` object: ``{"benchmark": "table3", "preset", "rows": [{"regime",
    "estimator", "loop", "rise_s", "settle_s", "rms_deg", ...}], "seconds", ...}``, with ``None``
    for a rise or settling time that a seed never reached, and ``"traces"`` of seed ``seed``'s
    runs for the figure.
    """
    check_count("repeats", repeats)
    check_choices("estimators", estimators, TABLE3_ESTIMATORS, what="estimator")
    t0 = time.perf_counter()
    load_recipe(recipe)  # a bad name fails before any fitting
    split = paper_split(recipe, seed, progress=progress)
    factory = model_factory(preset, seed)
    models, guards = {}, []
    for name in progress_bar(estimators, desc="fit", enable=progress):
        if name == ORACLE:
            models[name] = None
            continue
        with quiet_guard():  # its figures go into the result
            models[name] = factory(name).fit(split.calibration)
        if getattr(models[name], "guard_", None):
            guards.append({"method": name, **models[name].guard_})
    fitted_s = time.perf_counter() - t0
    result = closed_loop_tests(
        recipe, models, range(seed, seed + repeats), backend=backend, n_jobs=n_jobs, progress=progress
    )
    return {
        "benchmark": "table3",
        "preset": preset,
        "recipe": recipe,
        **result,
        "guards": guards,
        "seconds": time.perf_counter() - t0,
        "fit_seconds": fitted_s,
        "repeats": repeats,
    }


def _fmt(v, sd) -> str:
    return "  never " if v is None else f"{v:5.2f}±{sd:4.2f}"


def format_table3(result: dict) -> str:
    """Table III as text: ours (mean ± sd over seeds) beside the paper's."""
    lines = [
        f"table3 ({result['preset']} preset, {result['recipe']}, {result['repeats']} seeds, "
        f"{result['seconds']:.0f} s): rise / settle on ±0.5° [s], RMS [°]",
        f"{'regime':12s} {'estimator':18s} loop  {'rise':>10s} {'settle':>10s} {'rms':>10s}   paper (rise settle rms)"
        "   est. err [N]  torque err [N m]  interm. err [N]  load err [N m]  stick",
    ]
    for r in result["rows"]:
        p = r["paper"]
        paper = f"{p['rise_s']:.2f} {p['settle_s']:.2f} {p['rms_deg']:.2f}" if p else "-"
        lines.append(
            f"{r['regime']:12s} {r['estimator']:18s} {r['loop']:4d}  {_fmt(r['rise_s'], r['rise_s_sd'])} "
            f"{_fmt(r['settle_s'], r['settle_s_sd'])} {_fmt(r['rms_deg'], r['rms_deg_sd'])}   {paper:22s}"
            f"   {r['why']['estimate_rmse_n']:8.1f}  {r['why']['torque_error_nm']:12.3f}  "
            f"{r['why']['intermediate_rmse_n']:15.1f}  {r['why']['load_error_nm']:14.3f}  "
            f"{r['why']['stick_fraction']:.2f}"
        )
    for g in result.get("guards", []):
        if guard_fired(g):
            where = f"; worse on {worse_kinds_text(g)}" if worse_kinds_text(g) else ""
            lines.append(
                f"guard: {g['method']} validation RMSE {g['cascade_rmse']:.1f} N against its prior's "
                f"{g['prior_rmse']:.1f} N{where}"
            )
    return "\n".join(lines)
