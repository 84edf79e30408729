"""Progress: a bar that shows on a terminal and degrades to nothing elsewhere (or without tqdm), and where
the work is, for the message of a Ctrl-C.

Every loop wrapped by :func:`progress_bar`, and every :func:`stage` block, records its position
whether or not a bar shows.  :func:`where` reads the position at the innermost point reached,
so the command line can say ``interrupted during fit pg-chtc, stage 1 (f_theta) epoch 12 of 40``.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import TypeVar

T = TypeVar("T")

# The open stages and loops, outermost first: [label, unit, items started, total or None]. ``_last``
# is the stack as it stood at the latest step; a block left by an exception does not update it, so
# that after a Ctrl-C it still names the point where the work stopped.
_stack: list[list] = []
_last: tuple = ()


def _snapshot() -> None:
    global _last
    _last = tuple(tuple(entry) for entry in _stack)


def _leave(entry: list, *, normal: bool) -> None:
    for i, open_entry in enumerate(_stack):
        if open_entry is entry:  # by identity: two loops may look alike
            del _stack[i]
            break
    if normal:
        _snapshot()


@contextmanager
def stage(label: str) -> Iterator[None]:
    """Name a phase of a long command (``"fit pg-chtc"``, ``"writing the report"``) for :func:`where`."""
    entry = [label, "", 0, None]
    _stack.append(entry)
    _snapshot()
    try:
        yield
    except BaseException:
        _leave(entry, normal=False)
        raise
    _leave(entry, normal=True)


def _tracked(iterable: Iterable[T], desc: str, total: int | None, unit: str) -> Iterator[T]:
    if total is None:
        try:
            total = len(iterable)  # type: ignore[arg-type]
        except TypeError:
            total = None
    entry = [desc, unit, 0, total]
    _stack.append(entry)
    _snapshot()
    try:
        for item in iterable:
            entry[2] += 1
            _snapshot()
            yield item
    except BaseException:
        # Also on GeneratorExit: a consumer stopped by an exception (a Ctrl-C in its body) closes the
        # loop only once that exception is handled, and the position must outlive it.  A loop left
        # early on purpose (early stopping) is then named until the next step or stage, which is soon.
        _leave(entry, normal=False)
        raise
    _leave(entry, normal=True)


def where() -> str:
    """Where the work was at the latest step: ``"fit pg-chtc, stage 1 (f_theta) epoch 12 of 40"``.

    Empty when no stage or loop has been entered since :func:`reset`.
    """
    parts = []
    for label, unit, started, total in _last:
        if not label:
            continue
        if not unit and total is None and started == 0:
            parts.append(label)
            continue
        count = f"{max(started, 1)} of {total}" if total is not None else f"{max(started, 1)}"
        parts.append(f"{label} {unit + ' ' if unit else ''}{count}".strip())
    return ", ".join(parts)


def reset() -> None:
    """Forget every position (the command line calls it as a command starts)."""
    _stack.clear()
    _snapshot()


def progress_bar(
    iterable: Iterable[T],
    *,
    desc: str = "",
    total: int | None = None,
    enable: bool | None = None,
    unit: str = "step",
) -> Iterator[T] | Iterable[T]:
    """Wrap ``iterable`` in a tqdm bar on stderr when ``enable`` (default: stderr is a terminal).

    Like emcee's, it quietly shows no bar when tqdm is missing.  Either way the position is
    recorded for :func:`where` (``unit`` names the items: ``"epoch"``).
    """
    if enable is None:
        enable = sys.stderr.isatty()
    shown = iterable
    if enable:
        try:
            from tqdm.auto import tqdm
        except ImportError:
            pass
        else:
            shown = tqdm(iterable, desc=desc, total=total, leave=False, file=sys.stderr)
    return _tracked(shown, desc, total, unit)


def epoch_progress(enable: bool | None = None) -> Callable[[Iterable[T], str], Iterable[T]]:
    """The ``progress(iterable, desc)`` hook of the training loops (:mod:`learners`): an epoch bar
    on a terminal, nothing elsewhere. ``learners`` cannot import this module (imports flow
    ``tendon_id -> learners``), so the zoo hands it in."""
    return lambda iterable, desc: progress_bar(iterable, desc=desc, enable=enable, unit="epoch")


def interrupt_message(written: list) -> str:
    """The one line a Ctrl-C prints: where the work stopped and which whole files it had written.

    ``"interrupted during fit pg-chtc, stage 1 (f_theta) epoch 12 of 40; nothing written"``.
    """
    at = where()
    done = "nothing written" if not written else "wrote only " + ", ".join(str(p) for p in dict.fromkeys(written))
    return f"interrupted{' during ' + at if at else ''}; {done}"
