"""The ``tendon-id`` command line (DESIGN §10).

Exit codes: 0 ok, 2 bad input (one line naming the file or option), 1 internal error.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path
from typing import Optional

import typer

from tendon_id.errors import TendonIdError

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
    protocol: str = typer.Option("posterior-3", "--protocol", help="terminal-only, posterior-3, posterior-6, planned-paths or single-passage."),
    effects: Optional[str] = typer.Option(None, "--effects", help="Comma-separated effects to switch on instead of the recipe's, or 'none'."),
    seed: Optional[int] = typer.Option(None, "--seed", help="Random seed (default: the recipe's). The same seed gives the same bytes."),
    frames: Optional[int] = typer.Option(None, "--frames", help="Total frames (default: the recipe's)."),
    out: Path = typer.Option(..., "--out", help="Output file, .parquet or .csv (with a .json sidecar)."),
) -> None:
    """Simulate one protocol of a recipe and write it as a recording."""
    from tendon_id.datasets import load_recipe
    from tendon_id.sim import simulate as run

    if out.suffix.lower() not in (".parquet", ".csv"):
        raise TendonIdError(f"--out {out}: the file must end in .parquet or .csv")
    rec = run(load_recipe(recipe), protocol, seed=seed, effects=effects, frames=frames).recording
    path = rec.write(out)
    typer.echo(f"wrote {path}: {rec.n_frames} frames, {len(rec.trajectories)} trajectories, {rec.n_modules} modules")


@app.command()
def info(
    file: Path = typer.Argument(..., help="A recording (.parquet, or .csv with an optional .json sidecar)."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
) -> None:
    """Summarise a recording: modules, frames, trajectories, ranges and which truth is present."""
    from tendon_id.data import Recording

    summary = Recording.read(file).summary()
    if as_json:
        typer.echo(json.dumps(summary, indent=2, default=float))
        return
    from tendon_id.report.text import format_summary

    typer.echo(format_summary(summary, str(file)))


@app.command()
def demo(
    out: Path = typer.Option(Path("out"), "--out", help="Folder for the demo's report."),
    recipe: str = typer.Option("snake12-paper", "--recipe", help="Recipe to run the demo on."),
    frames: Optional[int] = typer.Option(None, "--frames", help="Frames per protocol (default: the demo's small sizes)."),
) -> None:
    """The main job on the default recipe: simulate it and write OUT/summary.html."""
    from tendon_id.demo import run_demo

    path = run_demo(out, recipe=recipe, frames=frames)
    typer.echo(f"wrote {path}")


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit code."""
    command = typer.main.get_command(app)
    try:
        rv = command.main(args=argv, prog_name="tendon-id", standalone_mode=False)
        return int(rv) if isinstance(rv, int) else 0
    except typer.Exit as exc:  # --help and friends
        return exc.exit_code
    except typer.Abort:
        typer.echo("aborted", err=True)
        return 1
    except TendonIdError as exc:
        typer.echo(f"tendon-id: error: {exc}", err=True)
        return 2
    except KeyboardInterrupt:
        typer.echo("interrupted", err=True)
        return 130
    except Exception as exc:
        if hasattr(exc, "show") and hasattr(exc, "exit_code"):  # the parser's usage errors (exit code 2)
            exc.show()
            return int(exc.exit_code)
        if os.environ.get("TENDON_ID_DEBUG"):
            raise
        typer.echo(f"tendon-id: internal error: {type(exc).__name__}: {exc} (set TENDON_ID_DEBUG=1 for a traceback)", err=True)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
