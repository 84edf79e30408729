"""The ``tendon-id`` command line (DESIGN §10).

Exit codes: 0 ok, 2 bad input (one line naming the file or option), 1 internal error, 130
interrupted (Ctrl-C: one line saying where the work stopped and which whole files it wrote).

The long commands (fit, calibrate, identifiability, diagnose, benchmark, demo) check their
options, outputs and optional dependencies before the long part starts, name their phases for
the interrupt's message (:func:`tendon_id.progress.stage`), and hold a Ctrl-C over a group of
output files that belong together (:func:`tendon_id.atomic.hold_interrupt`).

The lists in the help texts (models, benchmarks, protocols, effects) come from their
registries. Each command imports what it runs inside its body, so that ``--help`` and a
mistyped option answer at once instead of after loading torch.
"""

from __future__ import annotations

import json
import os
import sys
import warnings
from contextlib import contextmanager, nullcontext
from pathlib import Path
from typing import Optional

import typer

from tendon_id.atomic import check_writable, hold_interrupt, json_text, record_writes
from tendon_id.benchmarks.registry import BENCHMARKS, PRESETS
from tendon_id.errors import TendonIdError
from tendon_id.extras import require_extra
from tendon_id.progress import interrupt_message, stage
from tendon_id.progress import reset as reset_progress
from tendon_id.sim.effects import EFFECT_NAMES
from tendon_id.sim.protocols import PROTOCOL_NAMES
from tendon_id.zoo.blocks import EFFECT_BLOCKS
from tendon_id.zoo.capstan import TYINGS, CapstanModel
from tendon_id.zoo.guard import quiet_guard
from tendon_id.zoo.passage import PASSAGE_BLOCKS, PassageCapstan, PassageModel
from tendon_id.zoo.registry import names as model_names
from tendon_id.zoo.registry import names_of


def _one_of(names) -> str:
    names = list(names)
    return ", ".join(names[:-1]) + f" or {names[-1]}" if len(names) > 1 else "".join(names)


MAPPING_HELP = "A mapping file (TOML) of your own files' columns and units, or a bundled one's name."

app = typer.Typer(
    name="tendon-id",
    help="Physics-informed identification of tendon transmissions in cable-driven snake robots.",
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)


@app.command()
def simulate(
    recipe: str = typer.Option("snake12-paper", "--recipe", help="Bundled recipe name or a recipe .toml file."),
    protocol: str = typer.Option("posterior-3", "--protocol", help=f"{_one_of(PROTOCOL_NAMES)}."),
    effects: Optional[str] = typer.Option(
        None,
        "--effects",
        help=f"Comma-separated effects to switch on instead of the recipe's ({', '.join(EFFECT_NAMES)}), or 'none'.",
    ),
    seed: Optional[int] = typer.Option(
        None, "--seed", help="Random seed (default: the recipe's). The same seed gives the same bytes."
    ),
    frames: Optional[int] = typer.Option(None, "--frames", help="Total frames (default: the recipe's)."),
    out: Path = typer.Option(..., "--out", help="Output file, .parquet or .csv (with a .json sidecar)."),
) -> None:
    """Simulate one protocol of a recipe and write it as a recording."""
    from tendon_id.datasets import load_recipe
    from tendon_id.sim import simulate as run

    check_writable(out, "--out", suffixes=(".parquet", ".csv"))
    with stage("simulate"):
        rec = run(load_recipe(recipe), protocol, seed=seed, effects=effects, frames=frames).recording
    with stage("writing the recording"), hold_interrupt():  # a .csv and its .json sidecar together
        path = rec.write(out)
    typer.echo(f"wrote {path}: {rec.n_frames} frames, {len(rec.trajectories)} trajectories, {rec.n_modules} modules")


@app.command()
def info(
    file: Path = typer.Argument(..., help="A recording (.parquet, or .csv with an optional .json sidecar)."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
    mapping: Optional[str] = typer.Option(None, "--mapping", help=MAPPING_HELP),
) -> None:
    """Summarise a recording: modules, frames, trajectories, ranges and which truth is present."""
    summary = _read_all([file], mapping)[0].summary()
    if as_json:
        typer.echo(json.dumps(summary, indent=2, default=float))
        return
    from tendon_id.report.text import format_summary

    typer.echo(format_summary(summary, str(file)))


def _parse_sets(items: list[str] | None) -> dict:
    """``key=value`` settings; values are read as JSON (numbers, lists, true/false) or else as text."""
    out = {}
    for item in items or []:
        if "=" not in item:
            raise TendonIdError(f"--set {item!r}: expected key=value")
        key, value = item.split("=", 1)
        try:
            out[key.strip()] = json.loads(value)
        except json.JSONDecodeError:
            out[key.strip()] = value
    return out


def _read_all(paths: list[Path], mapping: Optional[str] = None):
    from tendon_id.data.mapping import load_mapping, read_files
    from tendon_id.datasets import mapping_path

    if not paths:
        raise TendonIdError("--data: give at least one recording")
    return read_files(paths, load_mapping(mapping_path(mapping)) if mapping else None)


def _write_json(path: Path, obj: dict) -> None:
    from tendon_id.atomic import write_json_atomic

    write_json_atomic(path, obj)


@app.command()
def fit(
    model: str = typer.Argument(..., help=f"Zoo model: {_one_of(model_names())}."),
    data: list[Path] = typer.Option(None, "--data", help="Recording(s) to fit on; repeat for several."),
    set_: list[str] = typer.Option(None, "--set", help="Model setting key=value (JSON values); repeatable."),
    out: Path = typer.Option(..., "--out", help="Folder for the fitted model (model.json + arrays.npz)."),
    mapping: Optional[str] = typer.Option(None, "--mapping", help=MAPPING_HELP),
) -> None:
    """Fit a zoo model on terminal-only labels and save it."""
    from tendon_id import zoo

    check_writable(out, "--out", folder=True)
    m = zoo.make(model, **_parse_sets(set_))
    recs = _read_all(data, mapping)
    with stage(f"fit {model}"), quiet_guard(), _training_warnings():  # the guard is printed below, plainly
        m.fit(recs)
    with stage("writing the model"), hold_interrupt():  # model.json and arrays.npz: both or neither new
        m.save(out)
    frames = sum(r.n_frames for r in recs)
    typer.echo(f"fitted {model} on {frames} frames; saved to {out}")
    _echo_guard(m)


@contextmanager
def _training_warnings():
    """Show a training stopped by a non-finite loss as one line on stderr, every time it happens."""
    from learners.loop import NonFiniteLossWarning

    shown = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, NonFiniteLossWarning):
            typer.echo(f"tendon-id: warning: {message}", err=True)
        else:
            shown(message, category, filename, lineno, file, line)

    with warnings.catch_warnings():
        warnings.simplefilter("always", NonFiniteLossWarning)
        warnings.showwarning = show
        yield


def _echo_guard(m) -> None:
    """A learned cascade's validation RMSE against its calibrated prior's; the warning on stderr when worse."""
    from tendon_id.zoo.guard import guard_message

    guard = getattr(m, "guard_", None)
    if guard:
        first, *rest = guard_message(m.name, guard).split("\n")
        typer.echo(first)
        for line in rest:
            typer.echo(line, err=True)


@app.command()
def evaluate(
    model: Path = typer.Option(..., "--model", help="A folder written by 'tendon-id fit'."),
    data: Path = typer.Option(..., "--data", help="Recording to evaluate on."),
    as_json: bool = typer.Option(False, "--json", help="Print the metrics as JSON (DESIGN §10 shape)."),
    mapping: Optional[str] = typer.Option(None, "--mapping", help=MAPPING_HELP),
) -> None:
    """Metrics of a fitted model on a recording: terminal joint, and every joint where truth exists."""
    from tendon_id import zoo

    m = zoo.load(model)
    rec = _read_all([data], mapping)[0]
    score = m.score(rec)
    result = {"model": m.name, "frames": rec.n_frames, **score}
    if as_json:  # standard JSON: an undefined R^2 (a constant reference) is null
        typer.echo(json_text(result, strict=True))
        return
    if "predicted" in score:  # a single passage
        p = score["predicted"]
        unit = "N m" if getattr(rec, "quantity", "") == "torque" else "N"
        typer.echo(f"{m.name} on {data} ({rec.n_frames} frames), predicting the {score['side']} side")
        typer.echo(f"RMSE {p['rmse']:.4g} {unit}   R2 {p['r2']:.3f}   max error {p['max_error']:.4g} {unit}")
        return
    t = score["terminal"]
    typer.echo(f"{m.name} on {data} ({rec.n_frames} frames)")
    _echo_guard(m)
    typer.echo(f"terminal joint     RMSE {t['rmse']:8.3f} N   R2 {t['r2']:7.3f}   max error {t['max_error']:8.3f} N")
    if score["joints"]:
        for j, mj in enumerate(score["joints"]["per_joint"], start=1):
            typer.echo(
                f"joint {j:2d}           RMSE {mj['rmse']:8.3f} N   R2 {mj['r2']:7.3f}   "
                f"max error {mj['max_error']:8.3f} N"
            )
        o = score["joints"]["overall"]
        if o:
            typer.echo(f"intermediate 2..{rec.n_modules - 1}  RMSE {o['rmse']:8.3f} N   R2 {o['r2']:7.3f}")


@app.command()
def calibrate(
    data: list[Path] = typer.Option(None, "--data", help="Recording(s) with terminal labels; repeat for several."),
    model: str = typer.Option(
        "capstan-nonsmooth",
        "--model",
        help=f"A capstan-family model ({_one_of(names_of(CapstanModel))}), or passage-capstan for a bench's files.",
    ),
    tying: Optional[str] = typer.Option(None, "--tying", help=f"{_one_of(TYINGS)} (capstan family; default tied)."),
    blocks: Optional[str] = typer.Option(
        None, "--blocks", help=f"passage-capstan's effect blocks, comma-separated ({', '.join(PASSAGE_BLOCKS)})."
    ),
    mapping: Optional[str] = typer.Option(None, "--mapping", help=MAPPING_HELP),
    posterior: bool = typer.Option(False, "--posterior", help="Also sample the emcee posterior."),
    out: Path = typer.Option(..., "--out", help="Output folder: calibration.json (+ posterior.json, corner.png)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the multi-start and of the sampler."),
) -> None:
    """Constrained calibration with nlopt (the law, or a passage's law and blocks), optionally its emcee posterior."""
    if posterior:
        require_extra("posterior", "--posterior (its corner plot)")
    check_writable(out, "--out", folder=True)
    from tendon_id.calibration_report import run_calibration

    names = [b.strip() for b in (blocks or "").split(",") if b.strip()]
    PassageCapstan(blocks=names).block_objects  # an unknown or repeated block fails before the data is read
    recs = _read_all(data, mapping)
    with stage(f"calibrate {model}" + (" and its posterior" if posterior else "")):
        written = run_calibration(
            recs, model=model, tying=tying, blocks=names, posterior=posterior, out=out, seed=seed, report=typer.echo
        )
    for path in written:
        typer.echo(f"wrote {path}")


@app.command(
    help="Reproduce a table of the paper on simulated data.\n\n\b\n"
    + "\n".join(f"{name:9s} {b.summary}" for name, b in BENCHMARKS.items())
)
def benchmark(
    name: str = typer.Argument(..., help=f"{_one_of(BENCHMARKS)}."),
    preset: str = typer.Option("fast", "--preset", help=f"{_one_of(PRESETS)} (size of the learned models)."),
    recipe: Optional[str] = typer.Option(None, "--recipe", help="Recipe (default: the benchmark's own)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the first data split."),
    repeats: Optional[int] = typer.Option(
        None,
        "--repeats",
        help="Random splits (table1, table2) or closed-loop seeds (table3) to average over (default 5, 3, 3).",
    ),
    json_out: Optional[Path] = typer.Option(None, "--json", help="Also write the result as JSON (DESIGN §10 shape)."),
    backend: str = typer.Option(
        "loky",
        "--backend",
        help="joblib backend of the sweep's, diagnosis's, regimes' and table3's jobs (loky, threading, dask, ray).",
    ),
    jobs: int = typer.Option(
        1, "--jobs", help="Parallel jobs of the sweep, diagnosis, regimes and table3 (joblib's n_jobs; -1: all cores)."
    ),
    points: int = typer.Option(
        5, "--points", help="Grid values per parameter of the sweep (log-spaced, operating point included)."
    ),
    quick: bool = typer.Option(False, "--quick", help="diagnosis: every effect once, at default magnitude."),
    out: Optional[Path] = typer.Option(
        None, "--out", help="regimes: also write the heat-map page; table3: the closed-loop page (HTML)."
    ),
) -> None:
    from tendon_id.benchmarks.registry import format_table, run_benchmark

    if repeats is not None and repeats < 1:
        raise TendonIdError("--repeats must be at least 1")
    kwargs: dict = {"seed": seed} if name in ("table1", "table2", "table3") else {}
    if repeats is not None and name in ("table1", "table2", "table3"):
        kwargs["repeats"] = repeats
    if recipe:
        kwargs["recipe"] = recipe
    if name == "sweep":
        kwargs.update(seed=seed, backend=backend, n_jobs=jobs, points=points)
    if name == "latency":
        kwargs.update(seed=seed)
    if out is not None and name not in ("regimes", "table3"):
        raise TendonIdError("--out: only the regimes and table3 benchmarks write a page")
    if out is not None and out.suffix.lower() not in (".html", ".htm"):
        raise TendonIdError(f"--out {out}: the page is an HTML file (.html)")
    if name == "table3":
        kwargs.update(backend=backend, n_jobs=jobs)
    if name == "regimes":
        kwargs.update(seed=seed, backend=backend, n_jobs=jobs)
    if name == "diagnosis":
        if recipe:
            raise TendonIdError("--recipe: the diagnosis benchmark simulates its own cases (see its guide)")
        kwargs.update(seed=seed, quick=quick, backend=backend, n_jobs=jobs)
    _check_benchmark(name, preset, json_out, out, recipe, backend if "backend" in kwargs else None, jobs)
    with stage(f"benchmark {name}"), _training_warnings():
        result = run_benchmark(name, preset=preset, **kwargs)
    typer.echo(format_table(result))
    with stage("writing the results"), hold_interrupt():
        if json_out:
            _write_json(json_out, result)
            typer.echo(f"wrote {json_out}")
        if out is not None and name == "regimes":
            from tendon_id.report.regimes import write_regimes_page

            typer.echo(f"wrote {write_regimes_page(result, out)}")
        if out is not None and name == "table3":
            from tendon_id.report.closed_loop import write_table3_page

            typer.echo(f"wrote {write_table3_page(result, out)}")


def _check_benchmark(name, preset, json_out, out, recipe, backend, jobs) -> None:
    """What a benchmark would otherwise refuse after its work: names, outputs, recipe, joblib backend."""
    if name not in BENCHMARKS:
        raise TendonIdError(f"unknown benchmark {name!r}; known: {', '.join(BENCHMARKS)}")
    if preset not in PRESETS:
        raise TendonIdError(f"--preset: unknown preset {preset!r}; known: {', '.join(PRESETS)}")
    if json_out is not None:
        check_writable(json_out, "--json", suffixes=(".json",))
    if out is not None:
        check_writable(out, "--out")
    if recipe:
        from tendon_id.datasets import load_recipe

        load_recipe(recipe)
    if backend is not None:  # dask or ray must be installed and registered; n_jobs a non-zero integer
        from tendon_id.benchmarks.jobs import job_runner

        job_runner(backend, jobs)


@app.command()
def identifiability(
    data: list[Path] = typer.Option(None, "--data", help="Recording(s) with terminal labels; repeat for several."),
    out: Path = typer.Option(Path("identifiability.html"), "--out", help="Self-contained HTML report."),
    json_out: Optional[Path] = typer.Option(None, "--json", help="Also write the JSON summary (DESIGN §10 shape)."),
    model: str = typer.Option(
        "auto", "--model", help="auto, capstan-contact or capstan-simple (smooth structure analysed)."
    ),
    noise_n: Optional[float] = typer.Option(
        None, "--noise-n", help="Load-cell noise in N (default: the recording's metadata, else 1 N)."
    ),
    learned: bool = typer.Option(
        False, "--learned", help="Also train tied and per-guide PG-CHTC (fast preset; minutes)."
    ),
    seeds: int = typer.Option(3, "--seeds", help="Seeds of the learned comparison."),
    seed: int = typer.Option(0, "--seed", help="Seed of the samplers and the frame subset."),
) -> None:
    """What terminal-only data determines: tied against per-guide laws, bands, and what to measure next."""
    from tendon_id.identifiability import StudySettings, analyse
    from tendon_id.identifiability.study import check_learned_inputs
    from tendon_id.report.identifiability import write_report

    if out.suffix.lower() not in (".html", ".htm"):
        raise TendonIdError(f"--out {out}: the report is an HTML file (.html)")
    check_writable(out, "--out")
    if json_out is not None:
        check_writable(json_out, "--json", suffixes=(".json",))
    if seeds < 1:
        raise TendonIdError("--seeds must be at least 1")
    settings = StudySettings(model=model, noise_n=noise_n, seed=seed)
    recs = _read_all(data)
    if learned:
        check_learned_inputs(recs)
    with stage("identifiability"), _training_warnings() if learned else nullcontext():
        result = analyse(recs, settings, learned=learned, learned_seeds=seeds)
    with stage("writing the report"), hold_interrupt():  # the page and its JSON together
        path = write_report(result, out, json_out)
    js = result.to_json()
    typer.echo(
        f"tied: rank {js['tied']['rank']}/{js['tied']['n_params']}; per-guide: rank {js['per_guide']['rank']}/"
        f"{js['per_guide']['n_params']} ({js['per_guide']['n_unidentifiable']} unidentifiable directions)"
    )
    typer.echo(f"instrument joint {js['advice']['instrument_joint']}; excite joints {js['advice']['excite_joints']}")
    typer.echo(f"wrote {path}" + (f" and {json_out}" if json_out else ""))


@app.command()
def diagnose(
    data: list[Path] = typer.Option(None, "--data", help="Training recording(s); repeat for several."),
    test: list[Path] = typer.Option(
        None,
        "--test",
        help="Held-out recording(s); without them, cross-validation by trajectory (by file for a bench).",
    ),
    base: str = typer.Option(
        ...,
        "--base",
        help=f"The base: a folder from 'tendon-id fit', or a zoo name ({_one_of(names_of(CapstanModel))}, "
        "or passage-capstan for a bench's files).",
    ),
    candidates: Optional[str] = typer.Option(
        None,
        "--candidates",
        help=f"Comma-separated candidate effects (default all: {', '.join(EFFECT_BLOCKS)}; for a passage: "
        f"{', '.join(PASSAGE_BLOCKS)}).",
    ),
    mapping: Optional[str] = typer.Option(None, "--mapping", help=MAPPING_HELP),
    out: Path = typer.Option(Path("diagnosis.html"), "--out", help="Self-contained HTML report."),
    json_out: Optional[Path] = typer.Option(None, "--json", help="Also write the JSON result."),
    jobs: int = typer.Option(1, "--jobs", help="Parallel refits (joblib; -1: every core)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the bootstrap."),
) -> None:
    """Where the gap of a capstan-family model lies, which unmodelled effect causes it, and how far it shrinks."""
    from tendon_id import zoo
    from tendon_id.diagnosis import DiagnosisSettings, candidate_names, check_base
    from tendon_id.diagnosis import diagnose as run
    from tendon_id.report.diagnosis import write_report

    if out.suffix.lower() not in (".html", ".htm"):
        raise TendonIdError(f"--out {out}: the report is an HTML file (.html)")
    if json_out is not None and json_out.suffix.lower() != ".json":
        raise TendonIdError(f"--json {json_out}: the file must end in .json")
    check_writable(out, "--out")
    if json_out is not None:
        check_writable(json_out, "--json")
    model = zoo.load_model(base) if Path(base).is_dir() else zoo.make(base)
    check_base(model)
    passage = isinstance(model, PassageModel)
    names = candidate_names(candidates, PASSAGE_BLOCKS if passage else None)
    train = _read_all(data, mapping)
    held = _read_all(test, mapping) if test else None
    with stage("diagnose"):
        result = run(model, train, held, names, settings=DiagnosisSettings(seed=seed), n_jobs=jobs)
    with stage("writing the report"), hold_interrupt():
        path = write_report(result, out, json_out)
    typer.echo(result.summary())
    typer.echo(f"wrote {path}" + (f" and {json_out}" if json_out else ""))


@app.command()
def demo(
    out: Path = typer.Option(Path("out"), "--out", help="Folder for the demo's report."),
    recipe: str = typer.Option("snake12-paper", "--recipe", help="Recipe to run the demo on."),
    frames: Optional[int] = typer.Option(
        None, "--frames", help="Frames per protocol in the summary (default: the demo's small sizes)."
    ),
    models: bool = typer.Option(
        True,
        "--models/--no-models",
        help="Train PG-CHTC and PG-CHTC-NS (fast) and calibrate capstan-nonsmooth for the comparison.",
    ),
) -> None:
    """The main job on the default recipe: simulate, compare capstan-nonsmooth and the cascades in OUT/summary.html."""
    from tendon_id.demo import run_demo

    check_writable(out, "--out", folder=True)
    with stage("demo"), _training_warnings():
        path = run_demo(out, recipe=recipe, frames=frames, models=models)
    typer.echo(f"wrote {path}")


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit code."""
    command = typer.main.get_command(app)
    reset_progress()
    with record_writes() as written:
        try:
            rv = command.main(args=argv, prog_name="tendon-id", standalone_mode=False)
            if rv == 130:  # typer's answer to a Ctrl-C (no command returns a number)
                return _interrupted(written)
            return int(rv) if isinstance(rv, int) else 0
        except (typer.Exit, typer.Abort) as exc:
            if isinstance(exc.__cause__, KeyboardInterrupt):  # typer turns a Ctrl-C into Exit(130), click into Abort
                return _interrupted(written)
            if isinstance(exc, typer.Exit):  # --help and friends
                return exc.exit_code
            typer.echo("aborted", err=True)
            return 1
        except KeyboardInterrupt:
            return _interrupted(written)
        except TendonIdError as exc:
            typer.echo(f"tendon-id: error: {exc}", err=True)
            return 2
        except Exception as exc:
            return _internal(exc)


def _interrupted(written: list) -> int:
    """Ctrl-C: one line, where the work stopped and which whole files were written; no traceback."""
    typer.echo(f"tendon-id: {interrupt_message(written)}", err=True)
    return 130


def _internal(exc: Exception) -> int:
    """A parser's usage error (its own exit code), or an internal error: one line, exit 1."""
    if hasattr(exc, "show") and hasattr(exc, "exit_code"):  # the parser's usage errors (exit code 2)
        exc.show()
        return int(exc.exit_code)
    if os.environ.get("TENDON_ID_DEBUG"):
        raise exc
    typer.echo(
        f"tendon-id: internal error: {type(exc).__name__}: {exc} (set TENDON_ID_DEBUG=1 for a traceback)", err=True
    )
    return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
