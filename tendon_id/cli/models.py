"""``tendon-id fit``, ``evaluate`` and ``calibrate``: a model of any family, fitted, scored and calibrated."""

from __future__ import annotations

import json
import time
from contextlib import nullcontext
from pathlib import Path
from typing import Optional

import typer

from tendon_id.atomic import check_writable, hold_interrupt
from tendon_id.checks import check_finite_result, one_of
from tendon_id.cli.app import app
from tendon_id.cli.common import (
    JsonOutput,
    check_fit_data,
    echo_guard,
    handed_over,
    json_option,
    mapping_option,
    parse_sets,
    read_all,
    training_warnings,
)
from tendon_id.errors import ConfigError
from tendon_id.extras import require_extra
from tendon_id.progress import stage
from tendon_id.zoo.guard import quiet_guard
from tendon_id.zoo.registry import names as model_names


@app.command()
def fit(
    model: str = typer.Argument(..., metavar="MODEL", help=f"Zoo model: {one_of(model_names())}."),
    data: list[Path] = typer.Option(None, "--data", metavar="FILE", help="Recording(s) to fit on; repeat for several."),
    set_: list[str] = typer.Option(
        None, "--set", metavar="KEY=VALUE", help="Model setting key=value (JSON values); repeatable."
    ),
    out: Path = typer.Option(
        ..., "--out", metavar="DIR", help="Folder for the fitted model (model.json + arrays.npz)."
    ),
    mapping: Optional[str] = mapping_option(),
    json_out: Optional[str] = json_option("what was fitted"),
) -> None:
    """Fit a zoo model on terminal-only labels and save it."""
    from tendon_id import zoo

    check_writable(out, "--out", folder=True)
    js = JsonOutput(json_out)
    m = zoo.make(model, **parse_sets(set_))
    m.check_settings()  # before the data is read
    recs = read_all(data, mapping)
    check_fit_data(recs, data)
    with js.lines():
        t0 = time.perf_counter()
        # Only a model trained with torch (one with a device) can stop on a NaN loss; the warning's
        # module imports torch, a quarter GB a physics model's fit need not pay.
        trains = training_warnings() if "device" in m.get_params() else nullcontext()
        frames = sum(r.n_frames for r in recs)
        with stage(f"fit {model}"), quiet_guard(), trains:  # the guard is printed below, plainly
            m.fit(handed_over(recs))  # the model's own: a physics model lets them go once it has their arrays
        seconds = time.perf_counter() - t0
        m.check_finite_fit(", ".join(map(str, data)))  # a diverged fit is an error naming its data
        with stage("writing the model"), hold_interrupt():  # model.json and arrays.npz: both or neither new
            m.save(out)
        typer.echo(f"fitted {model} on {frames} frames; saved to {out}")
        echo_guard(m)
        summary = {"model": model, "frames": frames, "out": str(out), "seconds": seconds}
        written = js.emit({**summary, "guard": getattr(m, "guard_", None)})
        if written:
            typer.echo(f"wrote {written}")


@app.command()
def evaluate(
    model: Path = typer.Option(..., "--model", metavar="DIR", help="A folder written by 'tendon-id fit'."),
    data: Path = typer.Option(..., "--data", metavar="FILE", help="Recording to evaluate on."),
    json_out: Optional[str] = json_option("the metrics"),
    mapping: Optional[str] = mapping_option(),
) -> None:
    """Metrics of a fitted model on a recording: what it predicts against what was measured, where truth exists."""
    from tendon_id import zoo

    js = JsonOutput(json_out)
    m = zoo.load(model)
    rec = read_all([data], mapping)[0]
    score = m.score(rec)
    # R^2 is undefined (null) for a constant reference; any other NaN is an error naming the data.
    check_finite_result(score, what=f"evaluating {m.name}", inputs=str(data), undefined=("r2",))
    with js.lines():
        first, *rest = m.family.score_lines(m, score, rec, str(data))
        typer.echo(first)
        echo_guard(m)
        for line in rest:
            typer.echo(line)
        # standard JSON: an undefined R^2 (a constant reference) is null
        written = js.emit({"model": m.name, "frames": rec.n_frames, **score})
        if written:
            typer.echo(f"wrote {written}")


@app.command()
def calibrate(
    data: list[Path] = typer.Option(
        None, "--data", metavar="FILE", help="Recording(s) with terminal labels; repeat for several."
    ),
    model: str = typer.Option(
        "capstan-nonsmooth",
        "--model",
        metavar="NAME",
        help="A model with a law: a snake's capstan model (capstan-simple, capstan-contact, capstan-nonsmooth, "
        "capstan-const-mu, capstan), or passage-capstan for a bench's files.",
    ),
    tying: Optional[str] = typer.Option(
        None, "--tying", metavar="TYING", help="tied or per-guide (a snake's law; default: tied)."
    ),
    blocks: Optional[str] = typer.Option(
        None,
        "--blocks",
        metavar="A,B,...",
        help="passage-capstan's effect blocks, comma-separated (stick_slip, smooth_edge, ...).",
    ),
    mapping: Optional[str] = mapping_option(),
    posterior: bool = typer.Option(
        False, "--posterior", metavar="", help="Also sample the emcee posterior (not with --each)."
    ),
    out: Path = typer.Option(
        ...,
        "--out",
        metavar="DIR",
        help="Output folder: calibration.json (+ posterior.json, corner.png); with --each, one such folder "
        "per file and fleet.json.",
    ),
    seed: int = typer.Option(0, "--seed", metavar="N", min=0, help="Seed of the multi-start and of the sampler."),
    each: bool = typer.Option(
        False,
        "--each",
        metavar="",
        help="One calibration per --data file, not one pooled over them: DIR/<file's stem>/ each, and "
        "DIR/fleet.json. Exit 2 if any file's data is refused, 1 if any fails otherwise.",
    ),
    n_jobs: int = typer.Option(
        1, "--jobs", metavar="N", help="With --each: files calibrated in parallel (joblib; -1: every core)."
    ),
    json_out: Optional[str] = json_option(
        "calibration.json's content (with --each, fleet.json's) and the files written"
    ),
) -> int:
    """Constrained calibration with nlopt (a snake's law, a passage's law and blocks), and its emcee posterior."""
    from tendon_id.report.calibration import calibration_model, run_calibration

    if each and posterior:
        raise ConfigError("--posterior is not taken with --each: sample each file's posterior on its own")
    if not each and n_jobs != 1:
        raise ConfigError("taken with --each only (one pooled calibration is one job)", param="n_jobs")
    if posterior:
        require_extra("posterior", "--posterior (its corner plot)")
    check_writable(out, "--out", folder=True)
    js = JsonOutput(json_out)
    settings = {"tying": tying} if tying is not None else {}
    if blocks is not None:
        settings["blocks"] = [b.strip() for b in blocks.split(",") if b.strip()]
    calibration_model(model, settings, seed)  # a bad model, setting or block fails before the data is read
    if each:
        return _calibrate_each(data, model, settings, mapping, out, seed, n_jobs, js)
    recs = read_all(data, mapping)
    check_fit_data(recs, data)
    with js.lines():
        with stage(f"calibrate {model}" + (" and its posterior" if posterior else "")):
            written = run_calibration(
                recs, model=model, settings=settings, posterior=posterior, out=out, seed=seed, report=typer.echo
            )
        for path in written:
            typer.echo(f"wrote {path}")
        calibration = json.loads((Path(out) / "calibration.json").read_text())
        summary = js.emit({"files": [str(p) for p in written], "calibration": calibration})
        if summary:
            typer.echo(f"wrote {summary}")
    return 0


def _calibrate_each(data, model, settings, mapping, out, seed, n_jobs, js) -> int:
    """``calibrate --each``: one result per file (:func:`tendon_id.report.fleet.calibrate_fleet`); the exit code.

    0 when every file is calibrated, 2 when a file's data is refused at fit time (bad input, as
    everywhere), 1 when one fails otherwise (an internal error); the others' results are kept either way.
    """
    from tendon_id.data.mapping import load_mapping
    from tendon_id.datasets import mapping_path
    from tendon_id.report.fleet import FLEET_FILE, calibrate_fleet

    if not data:
        raise ConfigError("give at least one recording", param="data")
    with js.lines():
        with stage(f"calibrate {model} on each of {len(data)} files"):
            doc = calibrate_fleet(
                data, model=model, settings=settings, out=out, seed=seed, n_jobs=n_jobs,
                mapping=load_mapping(mapping_path(mapping)) if mapping else None, report=typer.echo,
            )  # fmt: skip
        typer.echo(f"calibrated {doc['ok']} of {doc['files']} files; wrote {Path(out) / FLEET_FILE}")
        for e in doc["entries"]:
            if e["status"] != "ok":
                typer.echo(f"tendon-id: error: {e['file']}: {e['reason']}", err=True)
        written = [str(Path(out) / e["name"]) for e in doc["entries"] if e["status"] == "ok"]
        summary = js.emit({"files": [*written, str(Path(out) / FLEET_FILE)], "fleet": doc})
        if summary:
            typer.echo(f"wrote {summary}")
    return 1 if doc["failed"] else 2 if doc["refused"] else 0
