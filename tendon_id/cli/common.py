"""What several commands share: reading the data files, ``--set``, ``--json``, how a model's warnings are printed."""

from __future__ import annotations

import json
import sys
import warnings
from contextlib import contextmanager, redirect_stdout
from pathlib import Path

import typer

from tendon_id.atomic import check_writable, json_text, write_json_atomic
from tendon_id.errors import ConfigError

__all__ = [
    "MAPPING_HELP",
    "JsonOutput",
    "echo_guard",
    "json_option",
    "mapping_option",
    "parse_sets",
    "read_all",
    "geometry_warnings",
    "training_warnings",
]

MAPPING_HELP = "A mapping file (TOML) of your own files' columns and units, or a bundled one's name."


def mapping_option():
    """The ``--mapping MAP`` option that reads a user's own files."""
    return typer.Option(None, "--mapping", metavar="MAP", help=MAPPING_HELP)


def json_option(what: str):
    """The ``--json PATH`` option of every command that has one: ``what`` written to PATH, or printed with ``-``."""
    return typer.Option(
        None,
        "--json",
        metavar="PATH",
        help=f"Write {what} as JSON to PATH (.json), or to stdout with '-' (the other lines then go to stderr).",
    )


class JsonOutput:
    """Where a command's ``--json`` sends its JSON: a file, stdout (``-``), or nowhere (no ``--json``).

    Made before the long work, so that a path that cannot be written fails at once (exit code 2).

    Parameters
    ----------
    value : str or None
        The option's value.
    """

    def __init__(self, value: str | None):
        self.to_stdout = value == "-"
        self.path = None if value in (None, "-") else check_writable(Path(value), "--json", suffixes=(".json",))
        self._stdout = sys.stdout  # the real one: ``lines()`` swaps it for stderr

    @contextmanager
    def lines(self):
        """The command's other output: on stderr while the JSON goes to stdout, so that stdout parses as JSON.

        Anything printed through ``sys.stdout`` is moved, the library's own prints included.
        """
        if not self.to_stdout:
            yield
            return
        with redirect_stdout(sys.stderr):
            yield

    def emit(self, obj) -> Path | None:
        """Print or write ``obj`` (see :func:`tendon_id.atomic.json_text`); the path written, if any."""
        if self.to_stdout:
            self._stdout.write(json_text(obj) + "\n")
            self._stdout.flush()
            return None
        if self.path is not None:
            return write_json_atomic(self.path, obj)
        return None


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


#: Fewer frames than this and a fit is warned about: a law, a network or a play operator needs
#: a change between frames to be determined at all (the simulator's minimum is 2 too).
MIN_FIT_FRAMES = 2


def handed_over(items: list) -> list:
    """The items in a new list, ``items`` emptied: the callee then holds the only references.

    A model that lets its recordings go once it has read their arrays (issue 42's scale: an hour
    of a snake's log is 1.7 GiB) frees them only if the command does not keep them too.
    """
    out = list(items)
    items.clear()
    return out


def check_fit_data(recs: list, paths: list[Path]) -> None:
    """Warn, on standard error, of a fit on fewer than :data:`MIN_FIT_FRAMES` frames, naming the files.

    A warning, not an error: the library fits what it is given (its result is the start the data
    barely moved), and the command line agrees with it.
    """
    frames = sum(r.n_frames for r in recs)
    if frames < MIN_FIT_FRAMES:
        names = ", ".join(map(str, paths))
        typer.echo(
            f"warning: {names}: fitting on {frames} frame(s); nothing is determined by so few, and the fitted "
            "values are little more than the fit's starting point",
            err=True,
        )


def check_held_out(train: list[Path], test: list[Path] | None) -> None:
    """Refuse a held-out file that is also a training file: its error would not be held out."""
    both = {Path(p).resolve() for p in train} & {Path(p).resolve() for p in test or []}
    if both:
        raise ConfigError(f"{sorted(both)[0]} is both a training and a held-out file", param="test")


@contextmanager
def _warnings_as_lines(category: type[Warning], action: str):
    """Show warnings of ``category`` as ``tendon-id: warning:`` lines on stderr, filtered by ``action``."""
    shown = warnings.showwarning

    def show(message, cat, filename, lineno, file=None, line=None):
        if issubclass(cat, category):
            typer.echo(f"tendon-id: warning: {message}", err=True)
        else:
            shown(message, cat, filename, lineno, file, line)

    with warnings.catch_warnings():
        warnings.simplefilter(action, category)
        warnings.showwarning = show
        yield


def geometry_warnings():
    """Show each distinct defaulted-geometry warning once, as one line on stderr (the whole command)."""
    from tendon_id.errors import DefaultedGeometryWarning

    return _warnings_as_lines(DefaultedGeometryWarning, "once")


def training_warnings():
    """Show a training stopped by a non-finite loss as one line on stderr, every time it happens."""
    from learners.loop import NonFiniteLossWarning

    return _warnings_as_lines(NonFiniteLossWarning, "always")


def echo_guard(m) -> None:
    """A learned cascade's validation RMSE against its calibrated prior's; the warning on stderr when worse."""
    from tendon_id.zoo.guard import guard_message

    guard = getattr(m, "guard_", None)
    if guard:
        first, *rest = guard_message(m.name, guard).split("\n")
        typer.echo(first)
        for line in rest:
            typer.echo(line, err=True)
