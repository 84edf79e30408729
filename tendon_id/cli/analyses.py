"""``tendon-id identifiability`` and ``diagnose``: what the data can tell, and what the model misses."""

from __future__ import annotations

from contextlib import nullcontext
from pathlib import Path
from typing import Optional

import typer

from tendon_id.atomic import check_writable, hold_interrupt
from tendon_id.cli.app import app
from tendon_id.cli.common import (
    JsonOutput,
    check_held_out,
    handed_over,
    json_option,
    mapping_option,
    read_all,
    training_warnings,
)
from tendon_id.errors import ConfigError
from tendon_id.progress import stage


def check_html(out: Path, json_out: str | None) -> JsonOutput:
    """A report's HTML page and its optional JSON, checked writable before the work; where the JSON goes."""
    if out.suffix.lower() not in (".html", ".htm"):
        raise ConfigError(f"{out}: the report is an HTML file (.html)", param="out")
    check_writable(out, "--out")
    return JsonOutput(json_out)


def report_written(write_report, result, out: Path, js: JsonOutput) -> str:
    """Write the page and the JSON (``result.to_dict()``, standard JSON) together; ``"wrote ..."``."""
    with stage("writing the report"), hold_interrupt():  # the page and its JSON together
        path = write_report(result, out)
        written = js.emit(result.to_dict())
    return f"wrote {path}" + (f" and {written}" if written else "")


@app.command()
def identifiability(
    data: list[Path] = typer.Option(
        None, "--data", metavar="FILE", help="Recording(s) with terminal labels; repeat for several."
    ),
    out: Path = typer.Option(Path("identifiability.html"), "--out", metavar="FILE", help="Self-contained HTML report."),
    json_out: Optional[str] = json_option("the summary"),
    model: str = typer.Option(
        "auto", "--model", metavar="NAME", help="auto, capstan-contact or capstan-simple (smooth structure analysed)."
    ),
    noise_n: Optional[float] = typer.Option(
        None, "--noise-n", metavar="N", help="Load-cell noise in N (default: the recording's metadata, else 1 N)."
    ),
    learned: bool = typer.Option(
        False, "--learned", metavar="", help="Also train tied and per-guide PG-CHTC (fast preset; minutes)."
    ),
    seeds: int = typer.Option(3, "--seeds", metavar="N", help="Seeds of the learned comparison."),
    seed: int = typer.Option(0, "--seed", metavar="N", min=0, help="Seed of the samplers and the frame subset."),
    mapping: Optional[str] = mapping_option(),
) -> None:
    """What terminal-only data determines: tied against per-guide laws, bands, and what to measure next."""
    from tendon_id.checks import check_count
    from tendon_id.identifiability import StudySettings, analyse
    from tendon_id.identifiability.study import check_learned_inputs
    from tendon_id.report.identifiability import write_report

    js = check_html(out, json_out)
    check_count("seeds", seeds)
    settings = StudySettings(model=model, noise_n=noise_n, seed=seed)
    recs = read_all(data, mapping)
    if learned:
        check_learned_inputs(recs)
    with js.lines():
        with stage("identifiability"), training_warnings() if learned else nullcontext():
            result = analyse(handed_over(recs), settings, learned=learned, learned_seeds=seeds)
        wrote = report_written(write_report, result, out, js)
        d = result.to_dict()
        typer.echo(
            f"tied: rank {d['tied']['rank']}/{d['tied']['n_params']}; per-guide: rank {d['per_guide']['rank']}/"
            f"{d['per_guide']['n_params']} ({d['per_guide']['n_unidentifiable']} unidentifiable directions)"
        )
        # The page's first screen, warnings first: the advice only with its check's verdict.
        for sentence in d["summary"]:
            typer.echo(("warning: " if sentence["tone"] == "warning" else "") + sentence["text"])
        typer.echo(wrote)


@app.command()
def diagnose(
    data: list[Path] = typer.Option(None, "--data", metavar="FILE", help="Training recording(s); repeat for several."),
    test: list[Path] = typer.Option(
        None,
        "--test",
        metavar="FILE",
        help="Held-out recording(s); without them, cross-validation by trajectory (by file for a bench).",
    ),
    base: str = typer.Option(
        ...,
        "--base",
        metavar="MODEL",
        help="The base: a folder from 'tendon-id fit', or a zoo model with effect blocks (a snake's capstan "
        "model, or passage-capstan for a bench's files).",
    ),
    candidates: Optional[str] = typer.Option(
        None,
        "--candidates",
        metavar="A,B,...",
        help="Comma-separated candidate effects among the base family's blocks (default: all of them; "
        "a name it does not know is refused with the list).",
    ),
    mapping: Optional[str] = mapping_option(),
    out: Path = typer.Option(Path("diagnosis.html"), "--out", metavar="FILE", help="Self-contained HTML report."),
    json_out: Optional[str] = json_option("the result"),
    jobs: int = typer.Option(1, "--jobs", metavar="N", help="Parallel refits (joblib; -1: every core)."),
    seed: int = typer.Option(0, "--seed", metavar="N", min=0, help="Seed of the bootstrap."),
) -> None:
    """Where the gap of a model with effect blocks lies, which unmodelled effect causes it, and how far it shrinks."""
    from tendon_id import zoo
    from tendon_id.checks import check_jobs
    from tendon_id.diagnosis import DiagnosisSettings, candidate_names, check_base
    from tendon_id.diagnosis import diagnose as run
    from tendon_id.report.diagnosis import write_report

    check_jobs("jobs", jobs)
    js = check_html(out, json_out)
    model = zoo.load(base) if Path(base).is_dir() else zoo.make(base)
    check_base(model)
    names = candidate_names(candidates, model.family.blocks)
    check_held_out(data or [], test)
    recordings = {"train": read_all(data, mapping), "test": read_all(test, mapping, param="test") if test else None}
    with js.lines():
        with stage("diagnose"):
            # Passed on, not kept here: the diagnosis lets go of them once their signals are stacked.
            settings = DiagnosisSettings(seed=seed)
            result = run(model, recordings.pop("train"), recordings.pop("test"), names, settings=settings, n_jobs=jobs)
        wrote = report_written(write_report, result, out, js)
        typer.echo(result.summary())
        typer.echo(wrote)
