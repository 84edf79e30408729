"""What several commands share: reading the data files, ``--set``, and how a model's warnings are printed."""

from __future__ import annotations

import json
import warnings
from contextlib import contextmanager
from pathlib import Path

import typer

from tendon_id.errors import ConfigError

__all__ = ["MAPPING_HELP", "echo_guard", "parse_sets", "read_all", "training_warnings"]

MAPPING_HELP = "A mapping file (TOML) of your own files' columns and units, or a bundled one's name."


def parse_sets(items: list[str] | None) -> dict:
    """``key=value`` settings; values are read as JSON (numbers, lists, true/false) or else as text."""
    out = {}
    for item in items or []:
        if "=" not in item:
            raise ConfigError(f"{item!r}: expected key=value", param="set_")
        key, value = item.split("=", 1)
        try:
            out[key.strip()] = json.loads(value)
        except json.JSONDecodeError:
            out[key.strip()] = value
    return out


def read_all(paths: list[Path] | None, mapping: str | None = None, param: str = "data") -> list:
    """The recordings of ``paths``: our own files, or a user's through ``mapping`` (:mod:`tendon_id.data.mapping`)."""
    from tendon_id.data.mapping import load_mapping, read_files
    from tendon_id.datasets import mapping_path

    if not paths:
        raise ConfigError("give at least one recording", param=param)
    return read_files(paths, load_mapping(mapping_path(mapping)) if mapping else None)


@contextmanager
def training_warnings():
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


def echo_guard(m) -> None:
    """A learned cascade's validation RMSE against its calibrated prior's; the warning on stderr when worse."""
    from tendon_id.zoo.guard import guard_message

    guard = getattr(m, "guard_", None)
    if guard:
        first, *rest = guard_message(m.name, guard).split("\n")
        typer.echo(first)
        for line in rest:
            typer.echo(line, err=True)
