"""``tendon-id benchmark``: any benchmark of the registry, its options checked once before the work."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from tendon_id.atomic import check_writable, hold_interrupt
from tendon_id.benchmarks.registry import BENCHMARKS, PRESETS, get_benchmark
from tendon_id.checks import one_of
from tendon_id.cli.app import app
from tendon_id.cli.common import JsonOutput, json_option, training_warnings
from tendon_id.progress import stage


@app.command(
    help="Reproduce a table of the paper on simulated data.\n\n\b\n"
    + "\n".join(f"{name:9s} {b.summary}" for name, b in BENCHMARKS.items())
)
def benchmark(
    name: str = typer.Argument(..., metavar="NAME", help=f"{one_of(BENCHMARKS)}."),
    preset: str = typer.Option(
        "fast", "--preset", metavar="NAME", help=f"{one_of(PRESETS)} (size of the learned models)."
    ),
    recipe: Optional[str] = typer.Option(
        None, "--recipe", metavar="NAME", help="Recipe (default: the benchmark's own)."
    ),
    seed: Optional[int] = typer.Option(
        None, "--seed", metavar="N", min=0, help="Seed of the first data split (default 0)."
    ),
    repeats: Optional[int] = typer.Option(
        None,
        "--repeats",
        metavar="N",
        help="Random splits (table1, table2) or closed-loop seeds (table3) to average over (default 5, 3, 3).",
    ),
    json_out: Optional[str] = json_option("the result"),
    backend: Optional[str] = typer.Option(
        None,
        "--backend",
        metavar="NAME",
        help="joblib backend of the jobs of sweep, diagnosis, regimes and table3 (loky, threading, dask, ray; "
        "default loky).",
    ),
    n_jobs: Optional[int] = typer.Option(
        None,
        "--jobs",
        metavar="N",
        help="Parallel jobs of sweep, diagnosis, regimes and table3 (joblib's n_jobs; -1: all cores).",
    ),
    points: Optional[int] = typer.Option(
        None,
        "--points",
        metavar="N",
        help="sweep: grid values per parameter (log-spaced, operating point included; default 5).",
    ),
    quick: bool = typer.Option(
        False, "--quick", metavar="", help="diagnosis: every effect once, at default magnitude."
    ),
    out: Optional[Path] = typer.Option(
        None, "--out", metavar="FILE", help="The benchmark's page (HTML): regimes' heat map, table3's closed loop."
    ),
) -> None:
    b = get_benchmark(name)
    kwargs = b.arguments(
        preset, recipe=recipe, seed=seed, repeats=repeats, backend=backend, n_jobs=n_jobs, points=points,
        quick=quick or None,
    )  # fmt: skip
    js = JsonOutput(json_out)
    if out is not None:
        b.check_page(out)
        check_writable(out, "--out")
    from tendon_id.benchmarks.registry import format_table

    with js.lines():
        with stage(f"benchmark {name}"), training_warnings():
            result = b(**kwargs)
        typer.echo(format_table(result))
        with stage("writing the results"), hold_interrupt():
            # standard JSON, as every command's: an undefined number (NaN, infinity) is null
            written = js.emit(result)
            if written:
                typer.echo(f"wrote {written}")
            if out is not None:
                typer.echo(f"wrote {b.write_page(result, out)}")
