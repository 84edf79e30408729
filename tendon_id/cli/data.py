"""``tendon-id simulate``, ``convert`` and ``info``: a recording simulated or converted, and summarised."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from tendon_id.atomic import check_writable, hold_interrupt
from tendon_id.checks import one_of
from tendon_id.cli.app import app
from tendon_id.cli.common import JsonOutput, json_option, mapping_option, read_all
from tendon_id.datasets import DEFAULT_RECIPE
from tendon_id.progress import stage
from tendon_id.sim.effects import EFFECT_NAMES
from tendon_id.sim.protocols import PROTOCOL_NAMES


@app.command()
def simulate(
    recipe: str = typer.Option(
        DEFAULT_RECIPE, "--recipe", metavar="NAME", help="Bundled recipe name or a recipe .toml file."
    ),
    protocol: str = typer.Option("posterior-3", "--protocol", metavar="NAME", help=f"{one_of(PROTOCOL_NAMES)}."),
    effects: Optional[str] = typer.Option(
        None,
        "--effects",
        metavar="A,B,...",
        help=f"Comma-separated effects to switch on instead of the recipe's ({', '.join(EFFECT_NAMES)}), or 'none'.",
    ),
    seed: Optional[int] = typer.Option(
        None,
        "--seed",
        metavar="N",
        min=0,
        help="Random seed (default: the recipe's). The same seed gives the same bytes.",
    ),
    frames: Optional[int] = typer.Option(None, "--frames", metavar="N", help="Total frames (default: the recipe's)."),
    out: Path = typer.Option(
        ..., "--out", metavar="FILE", help="Output file, .parquet or .csv (with a .json sidecar)."
    ),
    json_out: Optional[str] = json_option("the recording's summary"),
) -> None:
    """Simulate one protocol of a recipe and write it as a recording."""
    from tendon_id.datasets import load_recipe
    from tendon_id.sim import simulate as run

    check_writable(out, "--out", suffixes=(".parquet", ".csv"))
    js = JsonOutput(json_out)
    with js.lines():
        with stage("simulate"):
            rec = run(load_recipe(recipe), protocol, seed=seed, effects=effects, frames=frames).recording
        with stage("writing the recording"), hold_interrupt():  # a .csv and its .json sidecar together
            path = rec.write(out)
        typer.echo(
            f"wrote {path}: {rec.n_frames} frames, {len(rec.trajectories)} trajectories, {rec.n_modules} modules"
        )
        written = js.emit({"path": str(path), **rec.describe()})
        if written:
            typer.echo(f"wrote {written}")


@app.command()
def convert(
    data: list[Path] = typer.Option(
        None, "--data", metavar="FILE", help="Your file(s) or ROS 2 bag(s), read through --mapping; repeat for several."
    ),
    mapping: str = typer.Option(..., "--mapping", metavar="MAP", help="The mapping file (TOML) that reads them."),
    out: Path = typer.Option(
        ..., "--out", metavar="FILE", help="The recording in the native format: .parquet, or .csv with a .json sidecar."
    ),
    json_out: Optional[str] = json_option("the recording's summary"),
) -> None:
    """Convert your files or ROS 2 bags, through a mapping, into one recording in the native format."""
    check_writable(out, "--out", suffixes=(".parquet", ".csv"))
    js = JsonOutput(json_out)
    with js.lines():
        with stage("reading"):
            recs = read_all(data, mapping)
            rec = recs[0] if len(recs) == 1 else type(recs[0]).concat(recs)
        with stage("writing the recording"), hold_interrupt():
            path = rec.write(out)
        typer.echo(
            f"wrote {path}: {rec.n_frames} frames, {len(rec.trajectories)} trajectories from {len(recs)} file(s)"
        )
        written = js.emit({"path": str(path), **rec.describe()})
        if written:
            typer.echo(f"wrote {written}")


@app.command()
def info(
    file: Path = typer.Argument(
        ..., metavar="FILE", help="A recording (.parquet, or .csv with an optional .json sidecar)."
    ),
    json_out: Optional[str] = json_option("the summary"),
    mapping: Optional[str] = mapping_option(),
) -> None:
    """Summarise a recording: modules, frames, trajectories, ranges and which truth is present."""
    js = JsonOutput(json_out)
    rec = read_all([file], mapping, param="file")[0]
    with js.lines():
        typer.echo(rec.summary(str(file)))
        written = js.emit(rec.describe())
        if written:
            typer.echo(f"wrote {written}")
