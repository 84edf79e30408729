"""``tendon-id export``: a fitted model's streaming step as ONNX or self-contained C (:doc:`/guide/deploying`)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from tendon_id.atomic import check_writable, hold_interrupt
from tendon_id.checks import check_choice, one_of
from tendon_id.cli.app import app
from tendon_id.cli.common import JsonOutput, json_option
from tendon_id.extras import require_extra
from tendon_id.progress import stage

#: As tendon_id.export has them (a test checks it), so that --help answers without importing the exporters.
FORMATS = ("onnx", "c")
EXPORTED = "pg-chtc, capstan-simple, capstan-contact, capstan-nonsmooth, capstan-const-mu, capstan"


@app.command(
    "export",
    help="Export a fitted model's streaming step (one frame, its state in and out) as ONNX, or as a self-contained "
    f"C source and header.\n\nModels: {EXPORTED}.",
)
def export_command(
    model: Path = typer.Argument(..., metavar="MODEL", help="A folder written by 'tendon-id fit'."),
    format: str = typer.Option(..., "--format", metavar="FORMAT", help=f"{one_of(FORMATS)}."),
    out: Path = typer.Option(
        ..., "--out", metavar="DIR", help="Folder for the export (export.json and model.onnx, or PREFIX.c and .h)."
    ),
    prefix: str = typer.Option(
        "tendon_model",
        "--prefix",
        metavar="NAME",
        help="C only: the name of the files, the state type and the functions (a C identifier).",
    ),
    json_out: Optional[str] = json_option("what was exported"),
) -> None:
    """``tendon-id export MODEL --format onnx|c --out DIR``: check everything, load the model, write the folder."""
    from tendon_id.export import check_out, export_model
    from tendon_id.export.c_source import check_prefix

    check_choice("format", format, FORMATS, what="export format")
    if format == "c":
        check_prefix(prefix)
    else:
        require_extra("export", "--format onnx")
    check_writable(out, "--out", folder=True)
    check_out(out)
    js = JsonOutput(json_out)
    from tendon_id import zoo

    m = zoo.load(model)
    with js.lines():
        with stage(f"export {m.name} to {format}"), hold_interrupt():  # the folder is renamed into place whole
            folder = export_model(m, format, out, prefix)
        files = sorted(p.name for p in folder.iterdir())
        typer.echo(f"exported {m.name} ({format}) to {folder}: {', '.join(files)}")
        written = js.emit({"model": m.name, "format": format, "out": str(folder), "files": files})
        if written:
            typer.echo(f"wrote {written}")
