"""Atomic file writes: readers see the old file or the whole new one, never half of it.

Also what the long commands need around their writes: a check that an output can be written,
made before the work starts; a journal of the files written; and a Ctrl-C held over a group of
files that belong together.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import signal
import tempfile
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from tendon_id.errors import ConfigError, OutputError, TendonIdError

try:  # POSIX; write_group only holds the interrupt without it
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None


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
    return atomic_write_all([(path, write)])[0]


def atomic_write_all(writes: Sequence[tuple[str | os.PathLike, Callable[[str], None]]]) -> list[Path]:
    """Write every file to a temporary file beside it, and only then rename them all into place.

    Either every file is new, or (an error in any write: a full disk, a Ctrl-C) none was replaced
    and no temporary file is left: a CSV and its sidecar, or a model's two files, never mix two
    writes. The renames themselves take no space and do not fail on a full disk.

    Raises
    ------
    OutputError
        For an ``OSError`` of the file system, naming the file that could not be written.
    """
    temps: list[tuple[str, Path]] = []
    current = None
    try:
        for target, write in writes:
            current = Path(target)
            current.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=f".{current.name}.", suffix=".tmp", dir=current.parent)
            os.close(fd)
            temps.append((tmp, current))
            write(tmp)
            os.chmod(tmp, 0o666 & ~_umask())
        for tmp, target in temps:
            current = target
            os.replace(tmp, target)
    except BaseException as exc:
        for tmp, _ in temps:
            Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OSError) and not isinstance(exc, TendonIdError):  # a full disk, a read-only folder
            raise OutputError(f"{current}: cannot be written ({exc.strerror or exc}); nothing was replaced") from exc
        raise
    paths = [target for _, target in temps]
    if _journal is not None:
        _journal.extend(paths)
    return paths


def write_folder_atomic(path: str | os.PathLike, files: dict[str, bytes]) -> Path:
    """Write ``files`` (name -> content) as the folder ``path``: into a temporary folder beside it, renamed into place.

    Readers see the old folder or the whole new one, never a mix.  An existing ``path`` is
    replaced (renamed aside, then removed): the caller checks first that it may be.  Names are
    plain file names; the files get the ordinary permissions, as :func:`atomic_write` gives.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent))
    except OSError as exc:
        raise OutputError(f"{path}: cannot be written ({exc.strerror or exc})") from exc
    old = None
    try:
        for name, content in files.items():
            if Path(name).name != name:
                raise ValueError(f"{name!r} is not a plain file name")
            (tmp / name).write_bytes(content)
            os.chmod(tmp / name, 0o666 & ~_umask())
        os.chmod(tmp, 0o777 & ~_umask())
        if path.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".old", dir=path.parent))
            os.replace(path, old / path.name)
        os.replace(tmp, path)
    except BaseException as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        if old is not None and (old / path.name).exists() and not path.exists():
            os.replace(old / path.name, path)  # put the old folder back
        if isinstance(exc, OSError) and not isinstance(exc, TendonIdError):
            raise OutputError(f"{path}: cannot be written ({exc.strerror or exc}); nothing was replaced") from exc
        raise
    finally:
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    if _journal is not None:
        _journal.extend(path / name for name in files)
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
    """Non-finite floats as null, recursively (numpy arrays and scalars included)."""
    if isinstance(o, np.ndarray):
        o = o.tolist()
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_finite(v) for v in o]
    if isinstance(o, float) or type(o).__name__.startswith("float"):
        return float(o) if math.isfinite(o) else None
    return o


def json_text(obj, *, sort_keys: bool = False) -> str:
    """``obj`` as indented standard JSON: numpy values converted, a non-finite number as ``null``.

    Python's ``NaN``/``Infinity`` tokens are not JSON (RFC 8259, section 6): ``JSON.parse`` and
    most parsers reject them, so an undefined value is written as ``null``, always.
    """
    return json.dumps(_finite(obj), indent=2, default=_jsonable, allow_nan=False, sort_keys=sort_keys)


def write_json_atomic(path: str | os.PathLike, obj) -> Path:
    """Write ``obj`` as indented JSON to ``path`` atomically (see :func:`json_text`)."""
    return write_text_atomic(path, json_text(obj) + "\n")


# ---- checks before long work, and what was written ------------------------------------------

_journal: list[Path] | None = None


@contextmanager
def record_writes() -> Iterator[list[Path]]:
    """Collect the paths that :func:`atomic_write` completes inside the block (a list, filled as they land).

    The command line reads it to say what a Ctrl-C left behind: only whole files, and which.
    """
    global _journal
    outer, _journal = _journal, []
    try:
        yield _journal
    finally:
        if outer is not None:
            outer.extend(_journal)
        _journal = outer


class Terminated(KeyboardInterrupt):
    """A SIGTERM, raised where a Ctrl-C would be, so that it unwinds the same way (temporary files removed)."""


def raise_terminated(signum, frame) -> None:
    """SIGTERM handler: raise :class:`Terminated` (the command line installs it for its run)."""
    raise Terminated(f"signal {signum}")


_HELD = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def hold_interrupt() -> Iterator[None]:
    """Hold a Ctrl-C (SIGINT) or a SIGTERM until the block ends, then deliver it.

    A model folder or a report with its JSON is several files, each written atomically; holding
    the interrupt over the group keeps the set consistent (no new ``arrays.npz`` beside an old
    ``model.json``).  Outside the main thread, where no signal handler can be set, it holds nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = {sig: signal.signal(sig, lambda signum, frame: caught.append(signum)) for sig in _HELD}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    for sig in dict.fromkeys(caught):  # each signal once, in the order it came
        if callable(previous[sig]):  # Python's SIGINT handler raises KeyboardInterrupt, ours Terminated
            previous[sig](sig, None)
        elif previous[sig] == signal.SIG_DFL:
            signal.raise_signal(sig)


@contextmanager
def write_group(folder: str | os.PathLike) -> Iterator[Path]:
    """Write files that belong together in ``folder``: one writer at a time, and no interrupt between them.

    An exclusive ``flock`` on the folder itself makes concurrent writers (two runs with one
    ``--out``) take turns, so the last one's files are all that is left, never a mix; the
    interrupt is held as :func:`hold_interrupt` holds it.  The lock needs no file of its own,
    so nothing is left behind.  Where ``fcntl`` is missing (Windows) only the interrupt is held.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    fd = os.open(folder, os.O_RDONLY)
    try:
        if fcntl is not None:
            fcntl.flock(fd, fcntl.LOCK_EX)
        with hold_interrupt():
            yield folder
    finally:
        os.close(fd)  # closing the descriptor releases the lock


def sha256_file(path: str | os.PathLike) -> str:
    """Hex SHA-256 of a file's bytes, read in 1 MiB blocks."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def check_writable(
    path: str | os.PathLike, option: str, *, folder: bool = False, suffixes: tuple[str, ...] | None = None
) -> Path:
    """Raise :class:`~tendon_id.errors.ConfigError` unless ``path`` can be written, before any long work.

    The nearest existing ancestor must be a writable folder (missing folders are created on
    writing), a file must not be a folder nor a folder a file, and a file must end in one of
    ``suffixes``.

    Parameters
    ----------
    path : path-like
    option : str
        The option that named it (``"--out"``), for the message.
    folder : bool
        ``path`` is a folder to write files in, rather than a file.
    suffixes : tuple of str, optional
        Allowed endings of a file, lower case with the dot (``(".html", ".htm")``).
    """
    path = Path(path)
    if suffixes and path.suffix.lower() not in suffixes:
        raise ConfigError(f"{option} {path}: the file must end in {' or '.join(suffixes)}")
    if folder and path.exists() and not path.is_dir():
        raise ConfigError(f"{option} {path}: is a file, not a folder")
    if not folder and path.is_dir():
        raise ConfigError(f"{option} {path}: is a folder, not a file")
    base = path if folder else path.parent
    existing = base
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise ConfigError(f"{option} {path}: {existing} is a file, so no folder can be made under it")
    # atomic_write needs to create a temporary file (and folders) here: write and search permission
    if not os.access(existing, os.W_OK | os.X_OK):
        raise ConfigError(f"{option} {path}: cannot write in {existing} (permission denied)")
    return path
