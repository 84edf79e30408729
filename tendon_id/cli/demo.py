"""``tendon-id demo``: the main job on the default recipe, in one command."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from tendon_id.atomic import check_writable
from tendon_id.cli.app import app
from tendon_id.cli.common import JsonOutput, json_option, training_warnings
from tendon_id.datasets import DEFAULT_RECIPE
from tendon_id.progress import stage


@app.command()
def demo(
    out: Path = typer.Option(Path("out"), "--out", metavar="DIR", help="Folder for the demo's report."),
    recipe: str = typer.Option(DEFAULT_RECIPE, "--recipe", metavar="NAME", help="Recipe to run the demo on."),
    frames: Optional[int] = typer.Option(
        None, "--frames", metavar="N", help="Frames per protocol in the summary (default: the demo's small sizes)."
    ),
    models: bool = typer.Option(
        True,
        "--models/--no-models",
        metavar="",
        help="Train PG-CHTC and PG-CHTC-NS (fast) and calibrate capstan-nonsmooth for the comparison.",
    ),
    json_out: Optional[str] = json_option("the pages written"),
) -> None:
    """The main job on the default recipe: simulate, compare capstan-nonsmooth and the cascades in OUT/summary.html."""
    from tendon_id.demo import run_demo

    check_writable(out, "--out", folder=True)
    js = JsonOutput(json_out)
    with js.lines():
        with stage("demo"), training_warnings():
            path = run_demo(out, recipe=recipe, frames=frames, models=models)
        typer.echo(f"wrote {path}")
        pages = sorted(str(p) for p in Path(out).glob("*.html"))
        written = js.emit({"summary": str(path), "pages": pages, "recipe": recipe})
        if written:
            typer.echo(f"wrote {written}")
