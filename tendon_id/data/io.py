"""Reading and writing recordings: Parquet, or CSV plus a sidecar JSON (:doc:`/guide/data`).

Metadata is stored as JSON under the key ``b"tendon_id"`` of the Parquet key-value schema
metadata, or in a sidecar ``.json`` file beside a CSV file (``x.csv`` -> ``x.json``). Files are
written atomically (:func:`tendon_id.atomic.atomic_write`) and Parquet output is byte-identical
for identical data and metadata.

The functions here move a DataFrame and a metadata dict to and from files; turning them into
a :class:`~tendon_id.data.Recording` (normalising, validating) is the caller's job.
"""

from __future__ import annotations

import csv
import json
import stat
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tendon_id.atomic import atomic_write, atomic_write_all, write_group
from tendon_id.data.columns import PANDAS_COW
from tendon_id.errors import OutputError, RecordingError

#: Key of the Parquet key-value schema metadata that holds the recording metadata (JSON).
META_KEY = b"tendon_id"

__all__ = [
    "SUFFIXES_PARQUET",
    "SUFFIXES_CSV",
    "PARQUET_OPTIONS",
    "sidecar",
    "meta_json",
    "first_line",
    "check_suffix",
    "check_unique_columns",
    "check_csv_header",
    "read_frame",
    "read_parquet",
    "release_arrow_memory",
    "released",
    "read_csv",
    "write_frame",
    "write_parquet",
]

#: File suffixes read and written as Parquet (compared in lower case).
SUFFIXES_PARQUET = (".parquet", ".pq")

#: File suffixes read and written as CSV with a sidecar JSON (compared in lower case).
SUFFIXES_CSV = (".csv",)

#: Fixed Parquet writer options: identical data and metadata give byte-identical files.
PARQUET_OPTIONS: dict[str, Any] = dict(
    compression="zstd",
    compression_level=3,
    use_dictionary=True,
    write_statistics=True,
    version="2.6",
    data_page_version="1.0",
    row_group_size=1 << 20,
    store_schema=True,
)


def _json_default(obj: Any) -> Any:
    # Robot geometry and seeds often arrive as numpy values; store them as plain JSON.
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, (set, frozenset, tuple)):
        return list(obj)
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def first_line(exc: BaseException) -> str:
    """The first line of an exception's message (its type's name when it has none)."""
    text = str(exc).strip().splitlines()
    return text[0] if text else type(exc).__name__


def meta_json(meta: Mapping[str, Any], **kw: Any) -> str:
    """Metadata as JSON text: sorted keys, numpy values as plain JSON, no NaN.

    Parameters
    ----------
    meta : mapping
        The metadata.
    **kw
        Passed to :func:`json.dumps` (``indent``, ``separators``).

    Raises
    ------
    TypeError, ValueError
        For a value JSON cannot hold (including NaN and inf).
    """
    return json.dumps(meta, sort_keys=True, default=_json_default, allow_nan=False, **kw)


def sidecar(path: Path) -> Path:
    """The metadata sidecar of a CSV file: ``x.csv`` -> ``x.json``."""
    return path.with_suffix(".json")


def check_regular_file(path: Path) -> None:
    """Raise RecordingError unless ``path`` is (or links to) a regular file.

    A FIFO would block the read for ever and a device such as ``/dev/zero`` never ends; neither
    is a recording, so neither is opened.
    """
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        raise RecordingError("no such file", file=str(path)) from None
    except OSError as exc:
        raise RecordingError(f"cannot be read ({first_line(exc)})", file=str(path)) from None
    if stat.S_ISDIR(mode):
        raise RecordingError("is a folder, not a file", file=str(path))
    if not stat.S_ISREG(mode):
        kind = (
            "a FIFO" if stat.S_ISFIFO(mode) else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "special"
        )
        raise RecordingError(f"is {kind}, not a regular file", file=str(path))


def check_suffix(path: Path) -> str:
    """Return the lower-case suffix of ``path``; raise RecordingError unless Parquet or CSV."""
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES_PARQUET + SUFFIXES_CSV:
        raise RecordingError(f"unknown file type '{path.suffix}'; expected .parquet or .csv", file=str(path))
    return suffix


def read_frame(path: Path) -> tuple[pd.DataFrame, dict[str, Any] | None]:
    """Read the data and metadata of a ``.parquet`` (or ``.pq``) or ``.csv`` file.

    Parameters
    ----------
    path : pathlib.Path
        The file. For CSV, metadata is read from :func:`sidecar` when it exists.

    Returns
    -------
    frame : pandas.DataFrame
        The data as stored (not normalised).
    meta : dict or None
        The metadata, or None when the file has none.

    Raises
    ------
    RecordingError
        Naming the file, for an unknown suffix, a missing or unreadable file, or unreadable
        metadata.
    """
    suffix = check_suffix(path)
    check_regular_file(path)
    if suffix in SUFFIXES_PARQUET:
        return read_parquet(path)
    return read_csv(path)


def read_parquet(path: Path) -> tuple[pd.DataFrame, dict[str, Any] | None]:
    """Read a Parquet file: the data, and the metadata under :data:`META_KEY` (or None)."""
    # pyarrow is imported on use: only Parquet needs it, so CSV users and `import tendon_id.data`
    # do without it.
    import pyarrow as pa
    import pyarrow.parquet as pq

    src = str(path)
    try:
        # The footer first: a repeated column name makes read_table fail with a cryptic message.
        schema = pq.read_schema(path)
        check_unique_columns(schema.names, src)
        frame = read_columns(path, schema)
    except (pa.ArrowException, OSError) as exc:
        raise RecordingError(f"not a readable Parquet file ({first_line(exc)})", file=src) from exc
    except MemoryError as exc:  # a footer's row count is what the arrays are sized by
        rows = pq.ParquetFile(path).metadata.num_rows
        raise RecordingError(f"{rows} rows of {len(schema.names)} columns do not fit in memory", file=src) from exc
    raw = (schema.metadata or {}).get(META_KEY)
    meta = None
    if raw is not None:
        try:
            meta = json.loads(raw.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
            # RecursionError: JSON nested deeper than Python's stack (a corrupt or hostile file).
            raise RecordingError(f"unreadable tendon_id metadata ({first_line(exc)})", file=src) from exc
        if not isinstance(meta, dict):
            raise RecordingError("tendon_id metadata is not a JSON object", file=src)
    return frame, meta


#: Columns decoded at once by :func:`read_columns` (a few MB each per row group of our files).
COLUMNS_AT_ONCE = 8


def read_columns(path: Path, schema) -> pd.DataFrame:
    """A Parquet file's data as a DataFrame, its float64 columns filled one row group at a time.

    ``pyarrow.parquet.read_table(path).to_pandas()`` holds the whole compressed file, the whole
    Arrow table and the DataFrame at once, and Arrow's allocator keeps the freed buffers: about
    3.2 times the float64 data at a peak on 10^6 frames of N = 12.  Here each float64 column is
    one preallocated array, filled from :data:`COLUMNS_AT_ONCE` column chunks of one row group at
    a time, and Arrow's allocator (mimalloc) gives the decoded chunks back before the next are
    read, so the peak is the data plus one such slice.  Kept until the end, as before, mimalloc's
    freed chunks made the bench's peak 2.8 times its float64 data at 3.6·10^6 frames, against
    2.2 now.  Other columns (the trajectory ids) are gathered as Arrow arrays and converted as
    ``to_pandas`` converts them.  A file written by pandas with its own metadata (an index to
    restore) is read whole, as before.

    Parameters
    ----------
    path : pathlib.Path
    schema : pyarrow.Schema
        The file's schema (:func:`pyarrow.parquet.read_schema`).

    Returns
    -------
    pandas.DataFrame
        The same frame as ``read_table(path).to_pandas()``: same columns, dtypes and values.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    if b"pandas" in (schema.metadata or {}):
        return pq.read_table(path).to_pandas()
    pool = pa.default_memory_pool()
    pf = pq.ParquetFile(path)
    n = pf.metadata.num_rows
    names = schema.names
    floats = {c: np.empty(n) for c, f in zip(names, schema) if f.type == pa.float64()}
    others: dict[str, list] = {c: [] for c in names if c not in floats}
    start = 0
    for g in range(pf.num_row_groups):
        rows = pf.metadata.row_group(g).num_rows
        for k in range(0, len(names), COLUMNS_AT_ONCE):
            part = pf.read_row_group(g, columns=names[k : k + COLUMNS_AT_ONCE])
            for c in part.column_names:
                col = part.column(c)
                if c in floats:
                    # Nulls read as NaN, as to_pandas gives them.
                    floats[c][start : start + rows] = col.to_numpy()
                else:
                    others[c].extend(col.chunks)
            part = col = None  # the decoded chunks, given back before the next are read
            pool.release_unused()
        start += rows
    columns = {c: floats[c] if c in floats else _pandas_column(others[c], schema.field(c).type) for c in names}
    del others
    pool.release_unused()
    return pd.DataFrame(columns, columns=names, copy=False)


def release_arrow_memory() -> None:
    """Have Arrow's allocator give back the memory it no longer uses.

    pandas' text columns live in Arrow's allocator (mimalloc), and so do the temporaries of
    checking them (factorizing the trajectory ids): freed, they stay mapped until released,
    36 MiB on the bench at 3.6·10^6 frames, a quarter of its float64 data.
    """
    if "pyarrow" in sys.modules:  # nothing to give back where nothing used Arrow
        sys.modules["pyarrow"].default_memory_pool().release_unused()


def released(recording):
    """``recording``, once it is read: :func:`release_arrow_memory` after each file."""
    release_arrow_memory()
    return recording


def _pandas_column(chunks: list, type_) -> pd.Series:
    """An Arrow column's chunks as ``Table.to_pandas`` converts a column (pandas' own string dtype for text)."""
    import pyarrow as pa

    return pa.table({"c": pa.chunked_array(chunks, type=type_)}).to_pandas()["c"]


def read_csv(path: Path) -> tuple[pd.DataFrame, dict[str, Any] | None]:
    """Read a CSV file, and the metadata of its :func:`sidecar` when it exists (else None)."""
    src = str(path)
    try:
        # Floats written with repr() must read back bit for bit: pandas >= 3 does that by
        # default (and deprecates the option), older pandas needs "round_trip".
        extra = {} if PANDAS_COW else {"float_precision": "round_trip"}
        frame = pd.read_csv(path, dtype={"trajectory": str}, skipinitialspace=True, **extra)
    except pd.errors.EmptyDataError as exc:
        raise RecordingError("the file is empty", file=src) from exc
    except (pd.errors.ParserError, UnicodeDecodeError, OSError, ValueError) as exc:
        raise RecordingError(f"not a readable CSV file ({first_line(exc)})", file=src) from exc
    frame = check_csv_header(path, frame)
    side = sidecar(path)
    meta = None
    if side.exists():
        check_regular_file(side)
        try:
            meta = json.loads(side.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
            raise RecordingError(f"unreadable metadata sidecar ({first_line(exc)})", file=str(side)) from exc
        if not isinstance(meta, dict):
            raise RecordingError("metadata sidecar is not a JSON object", file=str(side))
    return frame, meta


def check_unique_columns(names: Sequence[str], source: str) -> None:
    """Raise naming the first column name that occurs twice among ``names``."""
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise RecordingError("duplicate column", file=source, column=str(name))
        seen.add(name)


#: Separators of CSV dialects we do not read, and how to name them in an error.
_OTHER_SEPARATORS = {";": "';'", "\t": "tabs", "|": "'|'"}


def check_csv_header(path: Path, frame: pd.DataFrame) -> pd.DataFrame:
    """Check a CSV file's header line; return ``frame`` with its column names stripped of spaces.

    Raises for a repeated column name (pandas would rename the second ``x`` to ``x.1`` and silently
    keep both), a first line that is a comment, and columns separated by something else than
    ``,`` (the file then reads as one column).
    """
    src = str(path)
    if frame.shape[1] == 1:
        name = str(frame.columns[0])
        if name.lstrip().startswith("#"):
            raise RecordingError(
                f"the first line is a comment ({name.strip()[:40]!r}); the file must start with its header line "
                '(or read it through a mapping file with comment = "#")',
                file=src,
            )
        for sep, said in _OTHER_SEPARATORS.items():
            if sep in name:
                raise RecordingError(
                    f"the columns are separated by {said}; tendon-id reads comma-separated CSV "
                    f"(write it with ',', or read it through a mapping file with delimiter = {sep!r})",
                    file=src,
                )
    try:
        with open(path, encoding="utf-8-sig", newline="") as fh:
            header = next(csv.reader(fh, skipinitialspace=True), [])
    except (csv.Error, UnicodeDecodeError, OSError) as exc:  # e.g. a header longer than csv's field limit
        raise RecordingError(f"not a readable CSV file ({first_line(exc)})", file=src) from exc
    # Spaces around a name (an aligned export) are not part of it; empty names (trailing commas)
    # become pandas' distinct "Unnamed: k" extra columns.
    check_unique_columns([h.strip() for h in header if h.strip()], src)
    return frame.rename(columns=lambda c: c.strip() if isinstance(c, str) else c)


def write_frame(frame: pd.DataFrame, meta: Mapping[str, Any], path: Path) -> Path:
    """Write data and metadata atomically to ``.parquet`` (or ``.pq``) or ``.csv`` (+ ``.json``).

    Parameters
    ----------
    frame : pandas.DataFrame
        The data, in canonical form.
    meta : mapping
        The metadata; must be JSON serialisable.
    path : pathlib.Path
        Target file; its folder is created if needed.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    RecordingError
        For an unknown suffix, or data or metadata that cannot be written.
    """
    suffix = check_suffix(path)
    try:
        meta_json(meta)  # checked before any file is touched
    except (TypeError, ValueError) as exc:
        raise RecordingError(f"metadata is not JSON serialisable ({first_line(exc)})", file=str(path)) from exc
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        if suffix in SUFFIXES_PARQUET:
            write_parquet(frame, meta, path)
        else:
            write_csv_pair(frame, meta, path)
    except OutputError:
        raise  # names the file already
    except OSError as exc:
        raise RecordingError(f"cannot write ({first_line(exc)})", file=str(path)) from exc
    return path


def write_csv_pair(frame: pd.DataFrame, meta: Mapping[str, Any], path: Path) -> None:
    """Write a CSV file and its sidecar as one unit: both to temporary files, then both renamed into place.

    :func:`~tendon_id.atomic.write_group` makes concurrent writers to one folder take turns (the
    last writer's pair is what is left, never one's data with the other's metadata) and holds a
    Ctrl-C or SIGTERM until both files are in place; :func:`~tendon_id.atomic.atomic_write_all`
    replaces neither file when either write fails (a full disk).
    """
    text = meta_json(meta, indent=2) + "\n"
    with write_group(path.parent):
        atomic_write_all(
            [
                (sidecar(path), lambda tmp: Path(tmp).write_text(text, encoding="utf-8")),
                (path, lambda tmp: frame.to_csv(tmp, index=False, lineterminator="\n", encoding="utf-8")),
            ]
        )


def write_parquet(frame: pd.DataFrame, meta: Mapping[str, Any], path: Path) -> None:
    """Write a Parquet file atomically with :data:`PARQUET_OPTIONS` and only our metadata."""
    import pyarrow as pa  # on use, as in read_parquet
    import pyarrow.parquet as pq

    try:
        table = pa.Table.from_pandas(frame, preserve_index=False)
    except (pa.ArrowException, TypeError, ValueError) as exc:
        raise RecordingError(f"cannot convert to Parquet ({first_line(exc)})", file=str(path)) from exc
    if "trajectory" in table.column_names:
        # One string type whatever pandas' string storage is (object, python or pyarrow).
        idx = table.column_names.index("trajectory")
        table = table.set_column(idx, "trajectory", table.column(idx).cast(pa.string()))
    # Only our metadata: pandas' block would tie the bytes to the pandas version.
    table = table.replace_schema_metadata({META_KEY: meta_json(meta, separators=(",", ":")).encode("utf-8")})
    atomic_write(path, lambda tmp: pq.write_table(table, tmp, **PARQUET_OPTIONS))
