"""A user's own files, read through a mapping file (TOML) that names their columns and units (:doc:`/guide/data`).

A complete mapping, for a bench that logs one tendon's two load cells in mN and a motor
angle in degrees::

    kind = "passage"          # "passage" (one passage, a bench) or "snake" (our recording schema)
    quantity = "tension"      # passage only: "tension" [N] (one tendon) or "torque" [N m] (a pair)

    [file]
    comment = "#"             # lines starting with it are skipped (default: none)
    header = true             # the first row names the columns (default); false: number them from 1
    delimiter = ","
    trajectory = "file"       # one trajectory per file (default), or the column that holds its id

    [columns]                 # our name = its column (name or 1-based number), unit, scale, sign
    t = { column = "time_ms", unit = "ms" }
    input = { column = "F_motor", unit = "mN" }
    output = { column = "F_tip", unit = "mN", sign = -1 }
    position = { column = "motor", unit = "deg" }

    [geometry]
    wrap_angle = "infer"      # the passage's wrap: "infer", a number [rad], or "120 deg"

A value in SI is ``sign * scale * raw`` converted from ``unit`` (``scale`` is 1 unless the
column holds counts: ``unit = "N*m", scale = 3.9811e-5``, or ``unit = "turn / 8192"``).
``kind`` names the transmission family whose recording the file holds (:mod:`tendon_id.family`;
default ``"passage"``). The names ``[columns]`` may hold, the columns it must name, and the
family's own keys are its recording class's (:meth:`~tendon_id.data.frame.FrameRecording.mapped_signal`,
:meth:`~tendon_id.data.frame.FrameRecording.mapping_options`): for a passage
:data:`~tendon_id.data.passage.PASSAGE_COLUMNS` and ``position``, ``position_out``, ``wrap``,
with ``quantity`` and ``[geometry]``; for a snake the columns of
:func:`~tendon_id.data.column_names`, with ``[meta]`` for its metadata (``n_modules``, ``robot``).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tendon_id.checks import check_choice, check_keys
from tendon_id.data import rules
from tendon_id.data.io import check_regular_file, first_line, read_frame, released
from tendon_id.data.patterns import expand_columns
from tendon_id.data.rosbag import is_bag, read_bag
from tendon_id.data.units import DIMENSIONS, si_factor
from tendon_id.errors import ConfigError, RecordingError
from tendon_id.family.registry import DEFAULT_MAPPED, family_names, family_of_meta, get_family

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

__all__ = ["ColumnMap", "DataMapping", "load_mapping", "read_mapped", "read_files", "table", "trajectory_names"]

#: Top-level keys every mapping may have; a family's recording class reads its own besides
#: (:attr:`~tendon_id.data.frame.FrameRecording.mapping_keys`).
_TOP = {"kind", "file", "columns"}
_FILE = {"comment", "header", "delimiter", "trajectory", "clock"}
_COLUMN = {"column", "unit", "scale", "sign", "topic", "field"}


@dataclass(frozen=True)
class ColumnMap:
    """One signal: where it is, and the factor that brings it to SI.

    Attributes
    ----------
    name : str
        Our column name (``input``, ``t``, ``theta_1_x``, ...).
    column : str or int
        The user's column: a name, or a 1-based number.
    unit : str
        The unit of ``scale * raw``.
    factor : float
        ``value_SI = factor * raw`` (sign, scale and unit together).
    kind : str
        ``time``, ``angle``, ``tension`` or ``torque``.
    topic, field : str or None
        In a ROS 2 bag (:mod:`tendon_id.data.rosbag`): the topic and the message field
        (``position[3]``, ``wrench.force.z``) instead of a column.
    """

    name: str
    column: str | int | None
    unit: str
    factor: float
    kind: str
    topic: str | None = None
    field: str | None = None


@dataclass(frozen=True)
class DataMapping:
    """A parsed mapping file (see the module docstring).

    ``kind`` is the family's name; ``options`` its recording class's own settings
    (:meth:`~tendon_id.data.frame.FrameRecording.mapping_options`: a passage's ``quantity`` and
    ``wrap_angle``, a snake's ``meta``).
    """

    source: str
    kind: str
    columns: tuple[ColumnMap, ...]
    comment: str | None = None
    header: bool = True
    delimiter: str = ","
    trajectory: str | int = "file"
    options: dict = field(default_factory=dict)
    clock: str | None = None

    @property
    def of_bags(self) -> bool:
        """Whether the mapping reads ROS 2 bags (its columns name topics and fields)."""
        return any(c.topic is not None for c in self.columns)

    @property
    def recording(self) -> type:
        """The recording class of the family the mapping describes."""
        return get_family(self.kind).recording


def table(doc: dict, key: str, allowed: set, where: str) -> dict:
    """The table ``[key]`` of a mapping (empty if absent); ``allowed`` its keys (empty: any)."""
    t = doc.get(key, {})
    if not isinstance(t, dict):
        raise ConfigError(f"{where}: [{key}] must be a table")
    if allowed:
        check_keys(t, allowed, what=f"key of [{key}]", where=where)
    return t


def load_mapping(path: str | os.PathLike) -> DataMapping:
    """Read and check a mapping file.

    Raises
    ------
    ConfigError
        In one line naming the file and the key: unreadable TOML, an unknown key, kind or
        quantity, a column named twice or missing, an unknown unit or one of the wrong dimension.
    """
    src = str(path)
    try:
        if Path(path).exists():
            check_regular_file(Path(path))  # a FIFO or a device would never end the read
        doc = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError(f"{src}: no such mapping file") from None
    except RecordingError as exc:
        raise ConfigError(f"{src}: {exc.reason}") from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"{src}: not a readable TOML mapping ({first_line(exc)})") from None
    kind = check_choice(f"{src}: kind", doc.get("kind", DEFAULT_MAPPED), family_names(), what="kind")
    recording = get_family(kind).recording
    known = _TOP | set(recording.mapping_keys)
    check_keys(doc, known, what="key", where=src)
    options = recording.mapping_options(doc, src)
    f = table(doc, "file", _FILE, src)
    n_modules, n_tendons = recording.mapping_counts(options)
    cols = expand_columns(table(doc, "columns", set(), src), n_modules, n_tendons, src)
    columns = []
    for name, spec in cols.items():
        where = f"{src}: columns.{name}"
        sk = recording.mapped_signal(name, options)
        if sk is None:
            raise ConfigError(f"{where}: a {kind} has no column {name!r}")
        if isinstance(spec, (str, int)) and not isinstance(spec, bool):
            spec = {"column": spec}
        if not isinstance(spec, dict):
            raise ConfigError(f"{where}: expected a column name or {{ column = ..., unit = ... }}")
        check_keys(spec, _COLUMN, what="key", where=where)
        topic, fld = _topic_field(spec, where)
        if topic is None and "column" not in spec:
            raise ConfigError(f"{where}: no 'column' (the name or 1-based number of the file's column)")
        column = spec.get("column")
        bad = isinstance(column, bool) or not isinstance(column, (str, int)) or (isinstance(column, int) and column < 1)
        if topic is None and bad:
            raise ConfigError(f"{where}: column must be a name or a number from 1, got {column!r}")
        unit = spec.get("unit", DIMENSIONS[sk])
        scale, sign = spec.get("scale", 1.0), spec.get("sign", 1)
        try:  # TOML integers have any number of digits: a 400-digit one is no float
            ok = not isinstance(scale, bool) and isinstance(scale, (int, float)) and math.isfinite(float(scale))
        except OverflowError:
            ok = False
        if not ok or scale == 0:
            raise ConfigError(f"{where}: scale must be a finite, non-zero number, got {str(scale)[:40]!r}")
        if sign not in (1, -1) or isinstance(sign, bool):
            raise ConfigError(f"{where}: sign must be 1 or -1, got {sign!r}")
        factor = sign * float(scale) * si_factor(unit, sk, where=where)
        columns.append(ColumnMap(name, column, str(unit), factor, sk, topic, fld))
    names = {c.name for c in columns}
    bags = {c.topic is not None for c in columns}
    if len(bags) > 1:
        raise ConfigError(f"{src}: [columns] mixes file columns and bag topics; a mapping reads one or the other")
    # A bag's time is its messages' stamps (tendon_id.data.rosbag), not a column.
    needed = [n for n in recording.required_columns(options) if not (True in bags and n == "t")]
    missing = [n for n in needed if n not in names]
    if missing:
        raise ConfigError(f"{src}: [columns] does not name {', '.join(missing)}")
    return DataMapping(
        source=src,
        kind=kind,
        columns=tuple(columns),
        **_file_options(f, src),
        options=options,
        clock=_clock(f, src),
    )


def _file_options(f: dict, where: str) -> dict:
    """``[file]``'s comment, header, delimiter and trajectory, each checked for its type (TOML has no casts)."""
    comment, header, delimiter = f.get("comment"), f.get("header", True), f.get("delimiter", ",")
    if comment is not None and not (isinstance(comment, str) and len(comment) == 1):
        raise ConfigError(f"{where}: [file] comment must be one character such as '#', got {comment!r}")
    if not isinstance(header, bool):
        raise ConfigError(f"{where}: [file] header must be true or false (no quotes), got {header!r}")
    if not (isinstance(delimiter, str) and len(delimiter) == 1 and delimiter not in '"\r\n'):
        raise ConfigError(f"{where}: [file] delimiter must be one character such as ',', got {delimiter!r}")
    trajectory = f.get("trajectory", "file")
    if (
        isinstance(trajectory, bool)
        or not isinstance(trajectory, (str, int))
        or (isinstance(trajectory, int) and trajectory < 1)
    ):
        raise ConfigError(
            f"{where}: [file] trajectory must be 'file' or a column's name or number from 1, got {trajectory!r}"
        )
    return {"comment": comment, "header": header, "delimiter": delimiter, "trajectory": trajectory}


def _topic_field(spec: dict, where: str) -> tuple[str | None, str | None]:
    """A bag entry's topic and field, checked; (None, None) for a file column."""
    if "topic" not in spec and "field" not in spec:
        return None, None
    if "column" in spec:
        raise ConfigError(f"{where}: give a column (a file) or a topic and field (a ROS 2 bag), not both")
    topic, fld = spec.get("topic"), spec.get("field")
    if not isinstance(topic, str) or not topic.startswith("/"):
        raise ConfigError(f"{where}: topic must be a ROS topic name such as '/joint_states', got {topic!r}")
    if not isinstance(fld, str) or not fld:
        raise ConfigError(f"{where}: field must name the message's field, such as 'position[0]', got {fld!r}")
    return topic, fld


def _clock(f: dict, where: str) -> str | None:
    clock = f.get("clock")
    if clock is not None and (not isinstance(clock, str) or not clock.startswith("/")):
        raise ConfigError(f"{where}: [file] clock must be the topic whose stamps are the frames, got {clock!r}")
    return clock


def _read_raw(path: Path, m: DataMapping) -> pd.DataFrame:
    src = str(path)
    check_regular_file(path)
    try:
        if path.suffix.lower() in (".parquet", ".pq"):
            frame = pd.read_parquet(path)
        else:
            frame = pd.read_csv(
                path,
                comment=m.comment,
                header=0 if m.header else None,
                sep=m.delimiter,
                skipinitialspace=True,
                engine="c",
            )
    except pd.errors.EmptyDataError:
        raise RecordingError("the file has no data rows", file=src) from None
    except (pd.errors.ParserError, UnicodeDecodeError, OSError, ValueError, ImportError) as exc:
        raise RecordingError(f"not readable with the mapping {m.source} ({first_line(exc)})", file=src) from None
    if not m.header and path.suffix.lower() not in (".parquet", ".pq"):
        frame.columns = list(range(1, frame.shape[1] + 1))
    return frame


def _locate(frame: pd.DataFrame, column: str | int, name: str, m: DataMapping, src: str):
    """The file's column a mapping entry names: by name, else by 1-based number."""
    if column in frame.columns:
        return column
    if isinstance(column, int) and 1 <= column <= frame.shape[1]:
        return frame.columns[column - 1]
    have = ", ".join(map(str, frame.columns[:12])) + (" ..." if frame.shape[1] > 12 else "")
    raise RecordingError(
        f"no column {column!r}, which {m.source} maps to {name!r}; the file's columns: {have}", file=src
    )


def read_mapped(path: str | os.PathLike, mapping: DataMapping, *, trajectory: str | None = None):
    """One file read through ``mapping``, in SI units.

    Parameters
    ----------
    path : path-like
        CSV (any delimiter, comment lines) or Parquet.
    mapping : DataMapping
    trajectory : str, optional
        The trajectory id when the mapping says one per file (default: the file's stem).

    Returns
    -------
    FrameRecording
        The recording of the mapping's family; metadata records the file and the mapping.

    Raises
    ------
    RecordingError
        Naming the file, the user's column and the 0-based data row: a missing column, a value
        that is not a number, and (after sign and scale) a tension that is not positive.
    """
    path = Path(path)
    src = str(path)
    raw = _read_raw(path, mapping)
    out: dict[str, Any] = {}
    for c in mapping.columns:
        col = _locate(raw, c.column, c.name, mapping, src)
        label = f"{col} ({c.name})"
        rules.check_numeric(raw.rename(columns={col: label}), [label], source=src)
        values = c.factor * raw[col].to_numpy(dtype=np.float64, na_value=np.nan)
        rules.check_finite({label: values}, source=src)
        rules.check_representable({label: values}, source=src)
        if c.kind == "tension":
            bad = np.flatnonzero(values <= 0)
            if bad.size:
                r = int(bad[0])
                raise RecordingError(
                    f"tension {values[r]:g} N after the mapping's sign and scale (factor {c.factor:g} to N) is not "
                    f"positive; check sign and scale of columns.{c.name} in {mapping.source}",
                    file=src,
                    column=str(col),
                    row=r,
                )
        out[c.name] = values
    if mapping.trajectory == "file":
        out["trajectory"] = np.full(len(raw), trajectory or path.stem, dtype=object)
    else:
        col = _locate(raw, mapping.trajectory, "trajectory", mapping, src)
        out["trajectory"] = raw[col].astype(str).to_numpy()
    frame = pd.DataFrame(out)
    meta = {"source_files": [path.name], "mapping": Path(mapping.source).name}
    return mapping.recording.from_mapped(frame, meta, mapping.options, src)


def trajectory_names(paths: list[Path]) -> list[str]:
    """One trajectory id per file: its stem, or ``folder/stem`` where stems repeat."""
    stems = [p.stem for p in paths]
    if len(set(stems)) == len(stems):
        return stems
    return [re.sub(r"[\\/]+", "/", f"{p.parent.name}/{p.stem}") for p in paths]


def read_own(path: Path):
    """A file in our own format, as the recording of the family its metadata names.

    The family is :func:`~tendon_id.family.registry.family_of_meta`'s.
    """
    frame, meta = read_frame(path)
    return family_of_meta(meta).recording(frame, meta, source=str(path))


def read_files(paths, mapping: DataMapping | None = None) -> list:
    """Recordings from files: our own format, or a user's through ``mapping`` (one trajectory per file).

    Raises
    ------
    RecordingError
        Naming the file (and column and row) of the first problem; nothing is read past it.
    """
    paths = [Path(p) for p in paths]
    bags = [p for p in paths if is_bag(p)]
    if bags and (mapping is None or not mapping.of_bags):
        why = "a mapping that names its topics and fields" if mapping is None else f"{mapping.source} to name topics"
        raise RecordingError(f"a ROS 2 bag is read through {why} (--mapping)", file=str(bags[0]))
    if mapping is not None and mapping.of_bags:
        if len(bags) < len(paths):
            other = next(p for p in paths if p not in bags)
            raise RecordingError(f"{mapping.source} names bag topics, but this is no ROS 2 bag", file=str(other))
        return [released(read_bag(p, mapping, trajectory=n)) for p, n in zip(paths, trajectory_names(paths))]
    if mapping is None:
        return [released(read_own(p)) for p in paths]
    if mapping.trajectory == "file":
        return [released(read_mapped(p, mapping, trajectory=n)) for p, n in zip(paths, trajectory_names(paths))]
    return [released(read_mapped(p, mapping)) for p in paths]
