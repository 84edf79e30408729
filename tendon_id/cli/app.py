"""The ``tendon-id`` program: its Typer app and its entry point, which turns every outcome into an exit code.

Exit codes: 0 ok, 2 bad input (one line naming the file or option), 1 internal error, 130
interrupted (Ctrl-C: one line saying where the work stopped and which whole files it wrote).

A library error names the parameter whose value is wrong (:class:`~tendon_id.errors.ConfigError`);
here it is printed with the flag of the command that ran (``--frames`` for ``frames``).
"""

from __future__ import annotations

import os
import sys

import typer

from tendon_id.atomic import record_writes
from tendon_id.errors import ConfigError, TendonIdError
from tendon_id.progress import interrupt_message
from tendon_id.progress import reset as reset_progress

__all__ = ["app", "main"]

app = typer.Typer(
    name="tendon-id",
    help="Physics-informed identification of tendon transmissions in cable-driven snake robots.",
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
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
        except ConfigError as exc:
            typer.echo(f"tendon-id: error: {exc.message_for(flags(command, argv))}", err=True)
            return 2
        except TendonIdError as exc:
            typer.echo(f"tendon-id: error: {exc}", err=True)
            return 2
        except Exception as exc:
            return _internal(exc)


def flags(command, argv: list[str]) -> dict[str, str]:
    """Parameter name -> how the user wrote it (``--frames``, ``MODEL``), for the subcommand in ``argv``."""
    name = next((a for a in argv if not a.startswith("-")), None)
    sub = command.commands.get(name) if name else None
    out: dict[str, str] = {}
    for p in sub.params if sub is not None else []:
        out[p.name] = max(p.opts, key=len) if p.param_type_name == "option" else p.name.upper()
    return out


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
