"""A progress bar that shows on a terminal and degrades to nothing elsewhere (or without tqdm)."""

from __future__ import annotations

import sys
from collections.abc import Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")


def progress_bar(iterable: Iterable[T], *, desc: str = "", total: int | None = None, enable: bool | None = None) -> Iterator[T] | Iterable[T]:
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
