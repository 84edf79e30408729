"""A model's ``arrays.npz``, read with bounded work: only the arrays ``model.json`` lists, sizes checked first.

``numpy.load`` unpacks whatever member is asked for and believes each ``.npy`` header: a header
claiming 2^40 elements asks for terabytes, and a small deflated member can unpack to gigabytes
(a zip bomb). Here every member's header is read (a few hundred bytes) and checked before its data
is: its dtype must be a plain number or boolean (never an object, whose bytes would be a pickle,
nor a complex number, which no model saves), its element count times item size must be the bytes
the member holds, and those bytes may not exceed what the archive can plausibly hold
(:data:`MAX_INFLATION`). Where ``model.json`` records the members (a save since format 1's
``"arrays": {"members": ...}``), each shape and dtype must be the recorded one and no other
member may be there. Written for tendon-id: numpy has no bounded reader of an ``.npz``.

The ``.npy`` format: NEP 1, https://numpy.org/neps/nep-0001-npy-format.html.
"""

from __future__ import annotations

import math
import zipfile
import zlib
from pathlib import Path

import numpy as np

from tendon_id.errors import ConfigError

__all__ = ["MAX_INFLATION", "members_record", "read_arrays"]

#: Largest ratio of a member's unpacked size to its packed size. ``np.savez`` stores members
#: uncompressed (ratio 1); deflate compresses float weights by less than 2, and cannot exceed
#: about 1032 (RFC 1951's longest match); a ratio above this is a bomb, not an array.
MAX_INFLATION = 20.0
#: Below this many unpacked bytes a member is read whatever its ratio (a zero-filled small array).
_SMALL = 1 << 20
#: The kinds of dtype a model's arrays may have: float, signed and unsigned int, bool.
_KINDS = "fiub"


def members_record(arrays: dict[str, np.ndarray]) -> dict[str, dict]:
    """What ``model.json`` records of each array: ``{name: {"shape": [...], "dtype": "<f8"}}``."""
    return {k: {"shape": list(np.shape(v)), "dtype": np.asarray(v).dtype.str} for k, v in arrays.items()}


def read_arrays(path: Path, record: dict | None = None) -> dict[str, np.ndarray]:
    """The arrays of ``path`` (an ``.npz``), each checked before it is allocated.

    Parameters
    ----------
    path : Path
        The ``arrays.npz`` file.
    record : dict, optional
        :func:`members_record` of the save, from ``model.json``; None for a model saved before
        it was recorded (every member is read, with the same checks of its header and size).

    Raises
    ------
    ConfigError
        Naming the file and the member: not a zip, a member that is not a plain ``.npy`` array,
        an object, pickled or complex array, a header whose size disagrees with the bytes held,
        an unpacked size beyond :data:`MAX_INFLATION`, or a member the record does not list.
    """
    for name, entry in (record or {}).items():
        shape = entry.get("shape") if isinstance(entry, dict) else None
        if not (
            isinstance(shape, list)
            and all(isinstance(n, int) and not isinstance(n, bool) and n >= 0 for n in shape)
            and isinstance(entry.get("dtype"), str)
        ):
            raise ConfigError(f"model.json: its record of array {name!r} is not a shape and a dtype")
    try:
        with zipfile.ZipFile(path) as zf:
            infos = {i.filename: i for i in zf.infolist()}
            names = _wanted(path, infos, record)
            return {name: _read_member(path, zf, infos[name + ".npy"], (record or {}).get(name)) for name in names}
    # A damaged zip can name a compression method zipfile lacks, claim encryption (RuntimeError)
    # or hold a broken deflate stream (zlib.error): each is a file that is no npz of ours.
    except (zipfile.BadZipFile, EOFError, OSError, NotImplementedError, RuntimeError, zlib.error) as exc:
        raise ConfigError(f"{path}: not a readable .npz of arrays ({type(exc).__name__}: {exc})") from None


def _wanted(path: Path, infos: dict[str, zipfile.ZipInfo], record: dict | None) -> list[str]:
    """The member names to read (without ``.npy``): the record's, or every member of a file saved without one."""
    for name in infos:  # a name is a key (``prior/A``), never a path written to: still, no path tricks
        if not name.endswith(".npy") or name.startswith("/") or "\\" in name or ".." in name.split("/"):
            raise ConfigError(f"{path}: member {name!r} is not an array of a saved model")
    present = [n[: -len(".npy")] for n in infos]
    if record is None:
        return present
    extra = sorted(set(present) - set(record))
    if extra:
        raise ConfigError(f"{path}: holds array {extra[0]!r}, which model.json does not list")
    missing = sorted(set(record) - set(present))
    if missing:
        raise ConfigError(f"{path}: lacks array {missing[0]!r}, which model.json lists")
    return list(record)


def _read_member(path: Path, zf: zipfile.ZipFile, info: zipfile.ZipInfo, expected: dict | None) -> np.ndarray:
    name = info.filename[: -len(".npy")]
    where = f"{path}: array {name!r}"
    if info.file_size > _SMALL and info.file_size > MAX_INFLATION * max(info.compress_size, 1):
        raise ConfigError(
            f"{where} unpacks to {info.file_size} bytes from {info.compress_size}: not an array a model saves"
        )
    with zf.open(info) as f:
        try:
            version = np.lib.format.read_magic(f)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(f)
            else:
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(f)
        except ValueError as exc:
            raise ConfigError(f"{where} has no valid .npy header ({exc})") from None
        header = f.tell()
        if dtype.hasobject or dtype.kind not in _KINDS or dtype.fields is not None:
            what = "complex numbers" if dtype.kind == "c" else "objects (pickled data)" if dtype.hasobject else "them"
            raise ConfigError(f"{where} holds {what} (dtype {dtype}); a saved model's arrays are plain numbers")
        if expected is not None and (
            list(shape) != list(expected.get("shape", [])) or dtype.str != expected.get("dtype")
        ):
            raise ConfigError(
                f"{where} is {dtype.str} {tuple(shape)}, but model.json records "
                f"{expected.get('dtype')} {tuple(expected.get('shape', []))}"
            )
        need = math.prod(shape) * dtype.itemsize
        held = info.file_size - header
        if need != held:
            raise ConfigError(
                f"{where}: its header promises {need} bytes of data but the member holds {held}"
                + (" (cut off)" if held < need else "")
            )
        data = np.frombuffer(f.read(need), dtype=dtype)
    return data.reshape(shape, order="F" if fortran else "C").copy()
