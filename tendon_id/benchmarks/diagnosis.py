"""``tendon-id benchmark diagnosis``: how often the diagnosis names a withheld effect right (:doc:`/guide/benchmarks`).

Every case (:mod:`tendon_id.benchmarks.withheld`) is simulated, its base is calibrated on the
training data and :func:`tendon_id.diagnosis.diagnose` runs on it; an oracle refit of the true
structure gives the shrinkage the diagnosis should have found.  Cases are independent joblib
jobs, so ``backend="dask"`` runs them on a Dask cluster unchanged.
"""

from __future__ import annotations

import time
from collections import Counter

import numpy as np

from tendon_id.benchmarks.forms import family_of
from tendon_id.benchmarks.withheld import (
    BASE_FOR,
    LIBRARY,
    MAGNITUDES,
    OTHER_FORMS,
    OUT_OF_LIBRARY,
    Case,
    case_data,
    case_recipe,
)

#: Effects without a magnitude knob: the nonsmooth capstan's stick band is the friction itself, and
#: the inherited start state is whatever the session's unlogged motion leaves.
NO_MAGNITUDE = ("stick_slip", "start_state")
#: Pairs of withheld effects (both against capstan-nonsmooth).
PAIRS = (
    ("viscoelastic", "sensor_bias"),
    ("bending_stiffness", "velocity_friction"),
    ("guide_wear", "viscoelastic"),
    ("sensor_bias", "bending_stiffness"),
)
FULL = {"seeds": 5, "null_seeds": 20, "frames": 1000}
QUICK = {"seeds": 1, "null_seeds": 1, "frames": 1000}


def benchmark_cases(quick: bool = False, seed: int = 0) -> list[Case]:
    """The cases of the full benchmark, or of ``--quick`` (every effect once at default magnitude)."""
    size = QUICK if quick else FULL
    seeds = [seed + s for s in range(size["seeds"])]
    frames = size["frames"]
    out = []
    for effect in LIBRARY:
        mags = ["default"] if quick or effect in NO_MAGNITUDE else list(MAGNITUDES)
        out += [Case("single", (effect,), m, s, frames) for m in mags for s in seeds]
    out += [Case("null", (), "default", seed + s, frames) for s in range(size["null_seeds"])]
    out += [Case("out-of-library", (e,), "default", s, frames) for e in OUT_OF_LIBRARY for s in seeds]
    forms = list(OTHER_FORMS)[:1] if quick else list(OTHER_FORMS)
    out += [Case("other-form", (e,), "default", s, frames) for e in forms for s in seeds]
    pairs = PAIRS[:1] if quick else PAIRS
    out += [Case("pair", p, "default", s, frames) for p in pairs for s in seeds]
    return out


def run_case(case: Case) -> dict:
    """Simulate, calibrate the base, diagnose, and refit the oracle structure of one case."""
    from tendon_id import zoo
    from tendon_id.benchmarks.oracle import oracle_block
    from tendon_id.diagnosis import DiagnosisSettings, diagnose

    t0 = time.perf_counter()
    train, test = case_data(case)
    base = zoo.make(case.base).fit(train)
    result = diagnose(base, train, test, progress=False)
    row = {
        "kind": case.kind,
        "truth": list(case.truth),
        "magnitude": case.magnitude,
        "seed": case.seed,
        "base": case.base,
        "label": result.verdict.label,
        "verdict": result.verdict.kind,
        "rivals": list(result.verdict.rivals),
        "ladder": [r.effects[-1] for r in result.ladder[1:]],
        "base_rmse": result.base_rmse,
        "ladder_rmse": result.ladder[-1].heldout_rmse,
        "noise_floor": result.noise_floor,
        "noise_floor_upper": result.noise_floor_upper,
        "oracle_rmse": None,
        "detectable": None,
        # Where the floor alone showed no gap: the paired test's calibrated margin of the first rung.
        "null_margins": [g.margin for g in result.null_gains],
    }
    lib = case.library
    if lib:
        truth = case_recipe(case).effects
        robot = case_recipe(case).robot
        sensor_truth = train[0].meta.get("sensor_truth")  # the cells drawn for the training seed
        truth_blocks = tuple(oracle_block(e, truth, robot, sensor_truth) for e in LIBRARY if e in lib)
        structure = base.with_blocks(*truth_blocks)
        family = base.family
        # The base's fitted routing wrap (and clearance) where it has them; the oracle's blocks at the truth.
        start = (base.A_, base.B_, {**structure.block_params(), **base.block_params_})
        fit = family.refit(structure, base.inputs(train), start, DiagnosisSettings().max_nfev)
        e = family.residual(fit.model, base.inputs(test))
        row["oracle_rmse"] = float(np.sqrt(np.nanmean(e**2)))
        e0 = family.residual(base, base.inputs(test))
        structural = not any(b.param_names for b in truth_blocks)

        def null_margin():
            return _oracle_null_margin(result, family, base, structure, fit, train, test)

        row["detectable"] = _detectable(result, e0, e, test[0].sample_rate_hz, structural, null_margin)
    row["seconds"] = time.perf_counter() - t0
    return row


def _oracle_null_margin(result, family, base, structure, fit, train, test) -> float | None:
    """The paired margin the diagnosis would give the oracle structure: from its null gain, at ``1 - alpha``.

    Measured on the diagnosis's own draws where it made them, else on draws made here.
    """
    from tendon_id.diagnosis import DiagnosisSettings
    from tendon_id.diagnosis.calibrate import NullDraws

    s = DiagnosisSettings()
    draws = result.null_draws
    if draws is None:
        splits, _ = family.splits(family.recordings(train, "train"), family.recordings(test, "test"), s.folds, base)
        base_fit = family.refit(base, splits[0].training(), family.start(base), s.max_nfev)
        draws = NullDraws.simulate(family, splits, base, [base_fit], s, np.random.default_rng(s.seed))
    return None if draws is None else draws.gain((), structure, [fit], 1 - s.alpha).margin


def _detectable(result, e_base, e_oracle, rate_hz: float, structural: bool, null_margin=None) -> bool:
    """Whether the true structure itself passes the diagnosis's tests on this case.

    It does when its held-out improvement over the base is significant (the first rung's
    test, without the Bonferroni factor) and the base's error then shows a gap
    (:func:`~tendon_id.diagnosis.verdict.shows_gap`), by the floor or with the oracle as the
    first rung.  Its margin is calibrated as the diagnosis's is (``null_margin()``, computed only
    when the floor shows no gap), else the fixed one (``structural`` when none of its blocks
    has a free parameter).  A case that fails it carries its effect below what these data can
    show, so no diagnosis could name it; the benchmark reports top-1 over these cases too,
    beside the plain one.
    """
    from tendon_id.diagnosis import DiagnosisSettings
    from tendon_id.diagnosis.stats import NoiseFloor, improvement_ci
    from tendon_id.diagnosis.verdict import paired_margin, shows_gap

    s = DiagnosisSettings()
    block = max(int(round(s.block_s * rate_hz)), 1)
    lo, _ = improvement_ci(e_base, e_oracle, block, s.n_boot, 1 - 2 * s.alpha, np.random.default_rng(s.seed))
    if not lo > 0:
        return False
    floor = NoiseFloor(result.noise_floor, result.noise_floor_upper, result.noise_source)
    mse0, mse1 = float(np.nanmean(e_base**2)), float(np.nanmean(e_oracle**2))
    # Beyond the floor's upper quantile the excess over its mean is positive; its interval is not resampled here.
    excess = mse0 > floor.rmse**2
    if shows_gap(mse0, floor, excess, [], s):
        return True
    margin = null_margin() if null_margin is not None and s.null_draws else None
    return shows_gap(mse0, floor, excess, [(mse1, paired_margin(s, structural) if margin is None else margin)], s)


def summarise(rows: list[dict]) -> dict:
    """Confusion matrix, top-1 per magnitude, false alarms, out-of-library naming, pairs, shrinkage error."""
    library = list(LIBRARY)
    columns = library + ["none", "unexplained"]
    confusion: dict[str, Counter] = {}
    for r in rows:
        if r["kind"] in ("single", "null", "out-of-library", "other-form"):
            truth = r["truth"][0] if r["truth"] else "none"
            confusion.setdefault(truth, Counter())[r["label"]] += 1
    top1, detectable, or_rival = {}, {}, {}
    for mag in MAGNITUDES:
        sel = [r for r in rows if r["kind"] == "single" and r["magnitude"] == mag]
        if sel:
            top1[mag] = sum(r["label"] == r["truth"][0] for r in sel) / len(sel)
            # Named first, or reported as a rival that closes nearly as much (rows before rivals had none).
            or_rival[mag] = sum(r["truth"][0] in [r["label"], *r.get("rivals", [])] for r in sel) / len(sel)
            seen = [r for r in sel if r.get("detectable")]
            detectable[mag] = {
                "cases": len(seen),
                "of": len(sel),
                "top1": (sum(r["label"] == r["truth"][0] for r in seen) / len(seen)) if seen else None,
            }
    null = [r for r in rows if r["kind"] == "null"]
    ool = [r for r in rows if r["kind"] == "out-of-library"]
    forms = [r for r in rows if r["kind"] == "other-form"]
    pairs = [r for r in rows if r["kind"] == "pair"]
    errors = []
    for r in rows:
        if r["kind"] == "single" and r["oracle_rmse"] is not None:
            oracle = r["base_rmse"] - r["oracle_rmse"]
            if oracle > 0:
                errors.append(abs((r["base_rmse"] - r["ladder_rmse"]) - oracle) / oracle)
    return {
        "confusion": {t: {c: confusion[t].get(c, 0) for c in columns} for t in confusion},
        "columns": columns,
        "top1": top1,
        "top1_detectable": detectable,
        "top1_or_rival": or_rival,
        "null_false_alarm": (sum(r["label"] != "none" for r in null) / len(null)) if null else None,
        "ool_named": (sum(r["label"] in library for r in ool) / len(ool)) if ool else None,
        # An other-form case is right when its family is named (explained or in part), never "unexplained".
        "other_form_family": (sum(r["label"] == family_of(r["truth"][0]) for r in forms) / len(forms))
        if forms
        else None,
        "other_form_unexplained": (sum(r["verdict"] == "unexplained" for r in forms) / len(forms)) if forms else None,
        "pair_recovered": (sum(set(r["truth"]) <= set(r["ladder"][:2]) for r in pairs) / len(pairs)) if pairs else None,
        "median_shrinkage_error": float(np.median(errors)) if errors else None,
        "cases": len(rows),
    }


def run_cases(cases: list[Case], *, backend: str = "loky", n_jobs: int = 1) -> list[dict]:
    """:func:`run_case` of every case as independent joblib jobs (``backend="dask"`` for a Dask cluster)."""
    from joblib import Parallel, delayed, parallel_backend

    with parallel_backend(backend, n_jobs=n_jobs):
        return Parallel()(delayed(run_case)(c) for c in cases)


def diagnosis_benchmark(
    *, quick: bool = False, seed: int = 0, n_jobs: int = 1, backend: str = "loky", preset: str = "fast"
) -> dict:
    """Run every case as a joblib job and summarise (``preset`` is unused: no learned model is involved)."""
    t0 = time.perf_counter()
    rows = run_cases(benchmark_cases(quick, seed), backend=backend, n_jobs=n_jobs)
    return {
        "benchmark": "diagnosis",
        "quick": quick,
        "seed": seed,
        "bases": {**BASE_FOR, "other": "capstan-nonsmooth"},
        **summarise(rows),
        "rows": rows,
        "seconds": time.perf_counter() - t0,
    }


def format_diagnosis(r: dict) -> str:
    cols = r["columns"]
    short = {c: c[:6] for c in cols}
    lines = [f"diagnosis benchmark ({'quick' if r['quick'] else 'full'}, {r['cases']} cases, {r['seconds']:.0f} s)"]
    lines.append("confusion (rows: withheld truth; columns: the diagnosis's top verdict)")
    lines.append(f"  {'truth':18s} " + " ".join(f"{short[c]:>6s}" for c in cols))
    for truth, counts in r["confusion"].items():
        lines.append(f"  {truth:18s} " + " ".join(f"{counts[c]:6d}" for c in cols))
    for mag, acc in r["top1"].items():
        d = r.get("top1_detectable", {}).get(mag)
        extra = ""
        if d:
            extra = f"  (the true structure itself passes the tests in {d['cases']} of {d['of']} cases"
            extra += f"; top-1 on those: {d['top1']:.0%})" if d["top1"] is not None else ")"
        lines.append(f"top-1 at {mag} magnitude: {acc:.0%}{extra}")
        rival = r.get("top1_or_rival", {}).get(mag)
        if rival is not None and rival > acc:
            lines.append(f"  named first or as a rival that closes nearly as much: {rival:.0%}")

    def pct(v):
        return "n/a" if v is None else f"{v:.0%}"

    lines.append(f"null false alarms: {pct(r['null_false_alarm'])}")
    lines.append(f"out-of-library cases named as a library effect: {pct(r['ool_named'])}")
    if r.get("other_form_family") is not None:
        lines.append(
            f"other-form cases whose family is named: {pct(r['other_form_family'])}"
            f" (answered 'unexplained': {pct(r['other_form_unexplained'])})"
        )
    lines.append(f"pairs recovered in the first two rungs: {pct(r['pair_recovered'])}")
    lines.append(f"median shrinkage error against the oracle refit: {pct(r['median_shrinkage_error'])}")
    return "\n".join(lines)
