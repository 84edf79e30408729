"""The ``tendon-id`` program: its Typer app and its entry point, which turns every outcome into an exit code.

Exit codes: 0 ok, 2 bad input (one line naming the file or option), 1 internal error, 130
interrupted (Ctrl-C: one line saying where the work stopped and which whole files it wrote).

A library error names the parameter whose value is wrong (:class:`~tendon_id.errors.ConfigError`);
here it is printed with the flag of the command that ran (``--frames`` for ``frames``).

Every option that takes a value names it in ``--help`` with a metavar of its own (``PATH``,
``NAME``, ``N``), and flags show none, so the help reads the same under every typer since 0.12
(from 0.26 typer prints a Python type such as ``<list[Path]>`` or ``<bool>`` where none is given).
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from contextlib import contextmanager

import typer
import typer.core

from tendon_id import __version__
from tendon_id.atomic import raise_terminated, record_writes
from tendon_id.cli.common import geometry_warnings
from tendon_id.errors import ConfigError, TendonIdError
from tendon_id.progress import interrupt_message
from tendon_id.progress import reset as reset_progress

__all__ = ["app", "main"]


def _no_type(ctx=None) -> None:
    """No type to show beside a parameter."""
    return None


class _TidyHelp:
    """What the help of a command shows beside a parameter: its metavar, and nothing for a flag.

    Typer from 0.26 shows ``--help <bool>`` for the help flag, which takes no metavar of ours, and an
    argument's Python type after its metavar (``FILE <path>``); older typer shows neither.
    """

    def get_help_option(self, ctx):
        option = super().get_help_option(ctx)
        if option is not None:
            option.metavar = ""  # a flag: no value to name
        return option

    def get_params(self, ctx):
        params = super().get_params(ctx)
        for param in params:
            if param.param_type_name == "argument" and param.metavar:
                param.display_type_rich = _no_type  # the metavar says it (typer >= 0.26 only reads this)
        return params


class Command(_TidyHelp, typer.core.TyperCommand):
    """A ``tendon-id`` command (:class:`_TidyHelp`)."""


class Group(_TidyHelp, typer.core.TyperGroup):
    """The ``tendon-id`` program, whose commands are :class:`Command` (:class:`_TidyHelp`)."""


class _App(typer.Typer):
    """A Typer app whose commands are :class:`Command` unless told otherwise."""

    def command(self, *args, **kwargs):
        kwargs.setdefault("cls", Command)
        return super().command(*args, **kwargs)


app = _App(
    name="tendon-id",
    cls=Group,
    help="Physics-informed identification of tendon transmissions in cable-driven snake robots.",
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)


def _print_version(value: bool) -> None:
    if value:
        typer.echo(f"tendon-id {__version__}")
        raise typer.Exit()


@app.callback()
def _program(
    version: bool = typer.Option(
        False,
        "--version",
        metavar="",
        is_eager=True,  # before the check that a command is given
        callback=_print_version,
        help="Print the version (tendon-id X.Y.Z) and exit.",
    ),
) -> None:
    """The options of the program itself, before the command."""


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit code."""
    argv = bare_json(list(sys.argv[1:] if argv is None else argv))
    command = typer.main.get_command(app)
    reset_progress()
    with record_writes() as written, geometry_warnings(), sigterm_as_interrupt() as terms:
        try:
            rv = command.main(args=argv, prog_name="tendon-id", standalone_mode=False)
            if rv == 130:  # typer's answer to a Ctrl-C (no command returns a number)
                return _interrupted(written, terms)
            return int(rv) if isinstance(rv, int) else 0
        except (typer.Exit, typer.Abort) as exc:
            if isinstance(exc.__cause__, KeyboardInterrupt):  # typer turns a Ctrl-C into Exit(130), click into Abort
                return _interrupted(written, terms)
            if isinstance(exc, typer.Exit):  # --help and friends
                return exc.exit_code
            typer.echo("aborted", err=True)
            return 1
        except KeyboardInterrupt:
            return _interrupted(written, terms)
        except ConfigError as exc:
            typer.echo(f"tendon-id: error: {exc.message_for(flags(command, argv))}", err=True)
            return 2
        except TendonIdError as exc:
            typer.echo(f"tendon-id: error: {exc}", err=True)
            return 2
        except Exception as exc:
            return _internal(exc)


def bare_json(argv: list[str]) -> list[str]:
    """``argv`` with a bare ``--json`` read as ``--json -`` (print the JSON).

    ``info`` and ``evaluate`` had ``--json`` as a switch that printed; ``--json PATH`` and
    ``--json -`` are the convention now, and scripts written for the switch keep working.
    """
    out = []
    for i, arg in enumerate(argv):
        out.append(arg)
        after = argv[i + 1] if i + 1 < len(argv) else None
        if arg == "--json" and (after is None or (after.startswith("-") and after != "-")):
            out.append("-")
    return out


def flags(command, argv: list[str]) -> dict[str, str]:
    """Parameter name -> how the user wrote it (``--frames``, ``MODEL``), for the subcommand in ``argv``."""
    name = next((a for a in argv if not a.startswith("-")), None)
    sub = command.commands.get(name) if name else None
    out: dict[str, str] = {}
    for p in sub.params if sub is not None else []:
        out[p.name] = max(p.opts, key=len) if p.param_type_name == "option" else p.name.upper()
    return out


@contextmanager
def sigterm_as_interrupt():
    """For the run, a SIGTERM raises :class:`~tendon_id.atomic.Terminated`, which unwinds as a Ctrl-C does.

    So a ``kill`` or a job scheduler's stop removes the temporary files and reports what was
    written, as a Ctrl-C does (exit 143, 128 + SIGTERM). Yields the list of SIGTERMs received
    (the exception itself may reach :func:`main` as typer's exit code 130). Outside the main
    thread nothing changes.
    """
    received: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield received
        return

    def terminate(signum, frame):
        received.append(signum)
        raise_terminated(signum, frame)

    previous = signal.signal(signal.SIGTERM, terminate)
    try:
        yield received
    finally:
        signal.signal(signal.SIGTERM, previous)


def _interrupted(written: list, terms: list) -> int:
    """Ctrl-C or SIGTERM: one line, where the work stopped and which whole files were written; no traceback."""
    message = interrupt_message(written)
    if terms:
        typer.echo(f"tendon-id: terminated (SIGTERM); {message}", err=True)
        return 128 + signal.SIGTERM
    typer.echo(f"tendon-id: {message}", err=True)
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
