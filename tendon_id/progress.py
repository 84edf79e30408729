"""A progress bar that shows on a terminal and degrades to nothing elsewhere (or without tqdm)."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")


def progress_bar(
    iterable: Iterable[T], *, desc: str = "", total: int | None = None, enable: bool | None = None
) -> Iterator[T] | Iterable[T]:
    """Wrap ``iterable`` in a tqdm bar on stderr when ``enable`` (default: stderr is a terminal).

    Like emcee's, it quietly returns the iterable when tqdm is missing.
    """
    if enable is None:
        enable = sys.stderr.isatty()
    if not enable:
        return iterable
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return iterable
    return tqdm(iterable, desc=desc, total=total, leave=False, file=sys.stderr)


def epoch_progress(enable: bool | None = None) -> Callable[[Iterable[T], str], Iterable[T]]:
    """The ``progress(iterable, desc)`` hook of the training loops (:mod:`learners`): an epoch bar
    on a terminal, nothing elsewhere. ``learners`` cannot import this module (imports flow
    ``tendon_id -> learners``), so the zoo hands it in."""
    return lambda iterable, desc: progress_bar(iterable, desc=desc, enable=enable)
