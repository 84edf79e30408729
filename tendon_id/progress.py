"""Progress: a bar on a terminal, plain lines in a log, and where the work is, for the message of a Ctrl-C.

On a terminal, loops wrapped by :func:`progress_bar` show a tqdm bar on stderr (none without
tqdm).  When stderr is not a terminal (``make demo > log``, CI), bars would be noise, so the long
work says where it is in plain lines instead, a handful a minute at most:

* a :func:`stage` still running after :data:`ANNOUNCE_AFTER_S` seconds prints
  ``tendon-id: fit pg-chtc ...``, and ``tendon-id: fit pg-chtc done in 2 min 05 s`` when it ends;
* the outermost loop inside a stage prints its position (``tendon-id: benchmark table2, table2
  step 3 of 5``) at most every :data:`LOOP_EVERY_S` seconds; inner loops never do.

A quick stage says nothing, so a command that fails at once still prints one error line only, and
outside a stage (a library call, a joblib worker) no loop prints a line.

Every loop wrapped by :func:`progress_bar`, and every :func:`stage` block, records its position
whether or not anything shows.  :func:`where` reads the position at the innermost point reached,
so the command line can say ``interrupted during fit pg-chtc, stage 1 (f_theta) epoch 12 of 40``.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import TypeVar

T = TypeVar("T")

#: Seconds a stage runs before its plain line: quicker stages stay silent.
ANNOUNCE_AFTER_S = 5.0
#: Seconds between two plain lines of the outermost loop (and after any other plain line).
LOOP_EVERY_S = 30.0

# The open stages and loops, outermost first: [label, unit, items started, total or None, is a loop].
# ``_last`` is the stack as it stood at the latest step; a block left by an exception does not update
# it, so that after a Ctrl-C it still names the point where the work stopped.
_stack: list[list] = []
_last: tuple = ()

# The plain lines: a stage's line comes from a timer thread, hence the lock; ``_last_line`` is when the
# latest one was printed (time.monotonic), which spaces the loops' lines.
_lock = threading.RLock()
_last_line = float("-inf")


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


def plain_lines() -> bool:
    """Whether progress is told in plain lines: stderr is not a terminal (a file, a pipe, a test's capture)."""
    stream = sys.stderr
    if stream is None:  # pythonw: nowhere to write
        return False
    try:
        return not stream.isatty()
    except (AttributeError, ValueError):  # a closed or unusual stream
        return True


def _say(text: str) -> None:
    """One plain progress line on stderr."""
    global _last_line
    with _lock:
        _last_line = time.monotonic()
        if sys.stderr is not None:
            print(f"tendon-id: {text}", file=sys.stderr, flush=True)


def _duration(seconds: float) -> str:
    """``"12 s"``, ``"3 min 05 s"``, ``"1 h 02 min"``."""
    s = round(seconds)
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


class _Announcer:
    """A stage's plain lines: ``label ...`` once it has run ANNOUNCE_AFTER_S, ``label done in ...`` at its end."""

    def __init__(self, label: str):
        self.label = label
        self.t0 = time.monotonic()
        self.said = self.over = False
        self.timer = None
        if label and plain_lines():
            self.timer = threading.Timer(ANNOUNCE_AFTER_S, self._begin)
            self.timer.daemon = True  # never keeps the program alive
            self.timer.start()

    def _begin(self) -> None:
        with _lock:
            if not self.over:
                self.said = True
                _say(f"{self.label} ...")

    def end(self, *, normal: bool) -> None:
        if self.timer is not None:
            self.timer.cancel()
        with _lock:
            self.over = True
            # After an error or a Ctrl-C the command's own line says what happened.
            if self.said and normal:
                _say(f"{self.label} done in {_duration(time.monotonic() - self.t0)}")


@contextmanager
def stage(label: str) -> Iterator[None]:
    """Name a phase of a long command (``"fit pg-chtc"``, ``"writing the report"``).

    :func:`where` names it, and where stderr is not a terminal a stage that lasts says so in
    plain lines (see the module's text).
    """
    entry = [label, "", 0, None, False]
    _stack.append(entry)
    _snapshot()
    announcer = _Announcer(label)
    try:
        yield
    except BaseException:
        announcer.end(normal=False)
        _leave(entry, normal=False)
        raise
    announcer.end(normal=True)
    _leave(entry, normal=True)


def _outermost_loop_in_a_stage(entry: list) -> bool:
    """Whether ``entry`` is the first loop on the stack and a stage encloses it."""
    in_stage = False
    for open_entry in _stack:
        if open_entry is entry:
            return in_stage
        if open_entry[4]:
            return False
        in_stage = True
    return False


def _tracked(iterable: Iterable[T], desc: str, total: int | None, unit: str, plain: bool) -> Iterator[T]:
    if total is None:
        try:
            total = len(iterable)  # type: ignore[arg-type]
        except TypeError:
            total = None
    entry = [desc, unit, 0, total, True]
    _stack.append(entry)
    _snapshot()
    plain = plain and _outermost_loop_in_a_stage(entry)
    started = time.monotonic()
    try:
        for item in iterable:
            entry[2] += 1
            _snapshot()
            if plain:
                now = time.monotonic()
                if now - max(started, _last_line) >= LOOP_EVERY_S:
                    _say(where())
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
    for label, unit, started, total, _ in _last:
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
    global _last_line
    _stack.clear()
    _snapshot()
    _last_line = float("-inf")


def progress_bar(
    iterable: Iterable[T],
    *,
    desc: str = "",
    total: int | None = None,
    enable: bool | None = None,
    unit: str = "step",
) -> Iterator[T] | Iterable[T]:
    """Wrap ``iterable`` in a tqdm bar on stderr when ``enable`` (default: stderr is a terminal).

    Like emcee's, it quietly shows no bar when tqdm is missing.  With the default ``enable`` and
    stderr not a terminal, the outermost loop of a :func:`stage` prints a plain line now and then
    instead; ``enable=False`` keeps it silent.  Either way the position is recorded for
    :func:`where` (``unit`` names the items: ``"epoch"``).
    """
    plain = enable is None and plain_lines()
    if enable is None:
        enable = not plain_lines()
    shown = iterable
    if enable:
        try:
            from tqdm.auto import tqdm
        except ImportError:
            pass
        else:
            shown = tqdm(iterable, desc=desc, total=total, leave=False, file=sys.stderr)
    return _tracked(shown, desc, total, unit, plain)


def epoch_progress(enable: bool | None = None) -> Callable[[Iterable[T], str], Iterable[T]]:
    """The ``progress(iterable, desc)`` hook of the training loops (:mod:`learners`): an epoch bar
    on a terminal, plain lines now and then elsewhere (:func:`progress_bar`). ``learners`` cannot
    import this module (imports flow ``tendon_id -> learners``), so the zoo hands it in."""
    return lambda iterable, desc: progress_bar(iterable, desc=desc, enable=enable, unit="epoch")


def interrupt_message(written: list) -> str:
    """The one line a Ctrl-C prints: where the work stopped and which whole files it had written.

    ``"interrupted during fit pg-chtc, stage 1 (f_theta) epoch 12 of 40; nothing written"``.
    """
    at = where()
    done = "nothing written" if not written else "wrote only " + ", ".join(str(p) for p in dict.fromkeys(written))
    return f"interrupted{' during ' + at if at else ''}; {done}"
