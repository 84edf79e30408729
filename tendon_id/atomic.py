"""Atomic file writes: readers see the old file or the whole new one, never half of it."""

from __future__ import annotations

import json
import math
import os
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write(path: str | os.PathLike, write: Callable[[str], None]) -> Path:
    """Call ``write(tmp_path)`` on a temporary file beside ``path``, then rename it over ``path``.

    A failed write leaves any old file intact and removes the temporary file.  The
    new file gets the ordinary permissions (``0o666`` less the umask), not the
    owner-only mode of :func:`tempfile.mkstemp`.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    return atomic_write(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


def _jsonable(o):
    """numpy scalars and arrays as plain JSON values; anything else number-like as a float."""
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.integer, np.bool_)):
        return o.item()
    return float(o)


def _finite(o):
    """Non-finite floats as null, recursively."""
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_finite(v) for v in o]
    if isinstance(o, float) or type(o).__name__.startswith("float"):
        return float(o) if math.isfinite(o) else None
    return o


def write_json_atomic(path: str | os.PathLike, obj, *, strict: bool = False) -> Path:
    """Write ``obj`` as indented JSON to ``path`` atomically.

    numpy values are converted. ``strict`` writes non-finite numbers as ``null`` (standard
    JSON); otherwise they are written as Python's ``NaN``/``Infinity`` tokens.
    """
    if strict:
        obj = _finite(obj)
    text = json.dumps(obj, indent=2, default=_jsonable, allow_nan=not strict) + "\n"
    return write_text_atomic(path, text)
