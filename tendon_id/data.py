"""The data schema of tendon-id: a :class:`Recording` (design section 3).

A recording is one pandas DataFrame with one row per frame, plus metadata. Units are SI
throughout: time in s, angles in rad, tensions in N.

Columns (``N`` modules, ``k, j = 1..N``, tendon ``i = 1..3``):

========================  ===============================================================
``trajectory``            trajectory id (str); splits are made by trajectory, never by frame
``t``                     time within the trajectory [s], strictly increasing
``theta_{k}_x/_y``        joint angles [rad]
``tension_act_{j}_{i}``   actuator-side tension ``T[1, j, i]`` [N], measured for every set
``tension_joint_{N}_{i}`` terminal joint-side tension [N]: the only label a real robot gives
``tension_joint_{j}_{i}`` joint-side ground truth for ``j < N`` [N]; optional (simulation only),
                          for evaluation, never for fitting (see :meth:`Recording.fitting_view`)
========================  ===============================================================

Other columns are kept and ignored, so users may carry their own signals.

Metadata is stored as JSON under the key ``b"tendon_id"`` of the Parquet key-value schema
metadata, or in a sidecar ``.json`` file beside a CSV file (``x.csv`` -> ``x.json``).

This module depends on numpy, pandas and (for Parquet) pyarrow only; never on torch.
"""

from __future__ import annotations

import copy
import json
import math
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tendon_id.atomic import atomic_write
from tendon_id.errors import ConfigError, RecordingError

__all__ = ["SCHEMA_VERSION", "META_KEY", "DEFAULT_SAMPLE_RATE_HZ", "column_names", "Recording"]

#: Version of the column and metadata schema written by this module.
SCHEMA_VERSION = 1

#: Key of the Parquet key-value schema metadata that holds the recording metadata (JSON).
META_KEY = b"tendon_id"

#: Sample rate [Hz] assumed when the metadata does not give one and the time column cannot tell.
DEFAULT_SAMPLE_RATE_HZ = 10.0

_AXES = ("x", "y")
_TENDONS = (1, 2, 3)

# Module-numbered columns. Indices are matched without leading zeros so that ``theta_01_x`` is
# an extra column rather than silently taken for module 1.
_THETA_RE = re.compile(r"^theta_(0|[1-9][0-9]*)_([xy])$")
_TENSION_RE = re.compile(r"^tension_(act|joint)_(0|[1-9][0-9]*)_(0|[1-9][0-9]*)$")

_PANDAS_COW = int(pd.__version__.split(".")[0]) >= 3

_SUFFIXES_PARQUET = (".parquet", ".pq")
_SUFFIXES_CSV = (".csv",)

# Fixed Parquet writer options: identical data and metadata give byte-identical files.
_PARQUET_OPTIONS: dict[str, Any] = dict(
    compression="zstd",
    compression_level=3,
    use_dictionary=True,
    write_statistics=True,
    version="2.6",
    data_page_version="1.0",
    row_group_size=1 << 20,
    store_schema=True,
)


# --------------------------------------------------------------------------------------------
# column names
# --------------------------------------------------------------------------------------------

def _theta_columns(n: int) -> list[str]:
    return [f"theta_{k}_{a}" for k in range(1, n + 1) for a in _AXES]


def _act_columns(n: int) -> list[str]:
    return [f"tension_act_{j}_{i}" for j in range(1, n + 1) for i in _TENDONS]


def _joint_columns(j: int) -> list[str]:
    return [f"tension_joint_{j}_{i}" for i in _TENDONS]


def _truth_columns(n: int) -> list[str]:
    """Intermediate joint-side truth columns, ``j = 1..N-1`` (j-major)."""
    return [c for j in range(1, n) for c in _joint_columns(j)]


def column_names(n_modules: int, *, truth: bool = True) -> list[str]:
    """Canonical column names of a recording, in canonical order.

    Parameters
    ----------
    n_modules : int
        Number of modules ``N`` (>= 1).
    truth : bool, default True
        Include the intermediate joint-side truth columns ``tension_joint_{j}_{i}``, ``j < N``.
        The terminal columns ``tension_joint_{N}_{i}`` are always included.

    Returns
    -------
    list of str
        ``trajectory``, ``t``, the angles ``theta_{k}_x, theta_{k}_y`` (k-major), the actuator
        tensions ``tension_act_{j}_{i}`` (j-major), then the joint-side tensions
        ``tension_joint_{j}_{i}`` (j-major; only ``j = N`` when ``truth`` is False).
    """
    n = int(n_modules)
    if n < 1:
        raise ValueError(f"n_modules must be >= 1, got {n_modules!r}")
    joints = list(range(1, n + 1)) if truth else [n]
    return (["trajectory", "t"] + _theta_columns(n) + _act_columns(n)
            + [c for j in joints for c in _joint_columns(j)])


def _required_columns(n: int) -> list[str]:
    return column_names(n, truth=False)


def _module_index(column: str) -> int | None:
    """Module index a schema column refers to, or None for a column outside the schema."""
    m = _THETA_RE.match(column)
    if m:
        return int(m.group(1))
    m = _TENSION_RE.match(column)
    if m:
        return int(m.group(2))
    return None


def _infer_n_modules(columns: Sequence[str]) -> tuple[int | None, str | None]:
    """Largest module index among the schema columns, and the first column that carries it."""
    best, best_col = None, None
    for c in columns:
        k = _module_index(c)
        if k is not None and (best is None or k > best):
            best, best_col = k, c
    return best, best_col


# --------------------------------------------------------------------------------------------
# metadata
# --------------------------------------------------------------------------------------------

_META_ORDER = ("schema_version", "n_modules", "sample_rate_hz", "protocol", "robot", "recipe",
               "effects", "seed")


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


def _meta_json(meta: Mapping[str, Any], **kw: Any) -> str:
    return json.dumps(meta, sort_keys=True, default=_json_default, allow_nan=False, **kw)


def _is_int(x: Any) -> bool:
    return isinstance(x, (int, np.integer)) and not isinstance(x, (bool, np.bool_))


def _normalise_meta(meta: Mapping[str, Any] | None, source: str | None) -> dict[str, Any]:
    """Check the types of the known metadata keys and fill defaults (n_modules may stay None)."""
    if meta is None:
        meta = {}
    if not isinstance(meta, Mapping):
        raise RecordingError(f"metadata must be a mapping, got {type(meta).__name__}", file=source)
    raw = dict(meta)

    def bad(key: str, want: str) -> RecordingError:
        return RecordingError(f"metadata '{key}' must be {want}, got {raw[key]!r}", file=source)

    out: dict[str, Any] = {}
    version = raw.get("schema_version", SCHEMA_VERSION)
    if version is None:
        version = SCHEMA_VERSION
    if not _is_int(version) or version < 1:
        raise bad("schema_version", "a positive integer")
    if version > SCHEMA_VERSION:
        raise RecordingError(
            f"schema_version {version} is newer than this tendon-id understands "
            f"({SCHEMA_VERSION}); upgrade tendon-id", file=source)
    out["schema_version"] = int(version)

    n = raw.get("n_modules")
    if n is not None and (not _is_int(n) or n < 1):
        raise bad("n_modules", "a positive integer")
    out["n_modules"] = None if n is None else int(n)

    rate = raw.get("sample_rate_hz")
    if rate is not None:
        if isinstance(rate, (bool, np.bool_)) or not isinstance(rate, (int, float, np.number)) \
                or not math.isfinite(float(rate)) or float(rate) <= 0:
            raise bad("sample_rate_hz", "a positive number of Hz")
        rate = float(rate)
    out["sample_rate_hz"] = rate  # None is resolved from the time column by Recording

    for key in ("protocol", "recipe"):
        v = raw.get(key)
        if v is not None and not isinstance(v, str):
            raise bad(key, "a string or null")
        out[key] = v

    robot = raw.get("robot")
    if robot is not None and not isinstance(robot, Mapping):
        raise bad("robot", "a mapping or null")
    out["robot"] = None if robot is None else copy.deepcopy(dict(robot))

    effects = raw.get("effects")
    if effects is None:
        effects = []
    elif isinstance(effects, str):
        # "a,b" as the CLI writes it; "none" or "" means no effect.
        effects = [] if effects.strip().lower() in ("", "none") else \
            [e.strip() for e in effects.split(",") if e.strip()]
    if not isinstance(effects, (list, tuple)) or not all(isinstance(e, str) for e in effects):
        raise bad("effects", "a list of effect names")
    out["effects"] = list(effects)

    seed = raw.get("seed")
    if seed is not None and not _is_int(seed):
        raise bad("seed", "an integer or null")
    out["seed"] = None if seed is None else int(seed)

    # Unknown keys are kept (forward compatibility, user annotations).
    for key, v in raw.items():
        if key not in out:
            out[str(key)] = copy.deepcopy(v)
    return out


# --------------------------------------------------------------------------------------------
# small helpers
# --------------------------------------------------------------------------------------------

def _is_real_dtype(dtype: Any) -> bool:
    """True for integer or floating dtypes (numpy or pandas nullable), False for bool/str/complex."""
    kind = getattr(dtype, "kind", None)
    return kind in ("i", "u", "f")


def _float_column(frame: pd.DataFrame, column: str) -> np.ndarray:
    s = frame[column]
    if isinstance(s.dtype, np.dtype) and s.dtype == np.float64:
        return s.to_numpy()
    return s.to_numpy(dtype=np.float64, na_value=np.nan)


def _first_true(mask: np.ndarray) -> int | None:
    if mask.size and mask.any():
        return int(mask.argmax())
    return None


def _short(value: Any, width: int = 40) -> str:
    r = repr(value)
    return r if len(r) <= width else r[: width - 3] + "..."


def _sidecar(path: Path) -> Path:
    return path.with_suffix(".json")


# --------------------------------------------------------------------------------------------
# Recording
# --------------------------------------------------------------------------------------------

class Recording:
    """One recording: a frame-per-row DataFrame plus metadata (design section 3).

    Parameters
    ----------
    frame : pandas.DataFrame
        One row per frame, with the columns listed in :func:`column_names`. Extra columns are
        kept and ignored. The frame is copied (lazily under pandas copy-on-write), its index is
        reset, canonical columns are put first, ``trajectory`` is converted to str and the
        numeric schema columns to float64.
    meta : mapping, optional
        Metadata: ``schema_version`` (int), ``n_modules`` (int; inferred from the columns when
        missing), ``sample_rate_hz`` (float [Hz]; when missing, inferred from the median time step,
        else 10.0), ``protocol`` (str or None), ``robot`` (dict or None), ``recipe`` (str or None),
        ``effects`` (list of str), ``seed`` (int or None). Unknown keys are kept.
    source : str, optional
        File the data came from; named in error messages.
    validate : bool, default True
        Run :meth:`validate`.

    Raises
    ------
    RecordingError
        When the metadata or, with ``validate``, the data is invalid. The error names the file,
        the column and the 0-based frame row of the first offending value.

    Notes
    -----
    Treat :attr:`frame` as read-only. The array accessors return fresh float64 arrays in SI
    units: angles in rad, tensions in N, time in s.
    """

    __slots__ = ("_frame", "_meta", "_source")

    def __init__(self, frame: pd.DataFrame, meta: Mapping[str, Any] | None = None, *,
                 source: str | None = None, validate: bool = True):
        if not isinstance(frame, pd.DataFrame):
            raise TypeError(f"frame must be a pandas DataFrame, got {type(frame).__name__}")
        self._source = None if source is None else str(source)
        meta = _normalise_meta(meta, self._source)
        frame = self._normalise_frame(frame, meta)
        self._frame = frame
        if meta["n_modules"] is None:
            meta["n_modules"] = _infer_n_modules(list(frame.columns))[0]
        if meta["sample_rate_hz"] is None:
            meta["sample_rate_hz"] = self._infer_sample_rate()
        self._meta = {k: meta[k] for k in _META_ORDER}
        self._meta.update({k: v for k, v in meta.items() if k not in self._meta})
        if validate:
            self.validate()

    # ---- construction helpers ------------------------------------------------------------

    def _normalise_frame(self, frame: pd.DataFrame, meta: Mapping[str, Any]) -> pd.DataFrame:
        # Under copy-on-write (pandas >= 3) a shallow copy is already safe from later edits of
        # the caller's frame; before that, copy the data.
        frame = frame.copy(deep=not _PANDAS_COW)
        frame.columns = [str(c) for c in frame.columns]
        dup = frame.columns[frame.columns.duplicated()]
        if len(dup):
            raise RecordingError("duplicate column", file=self._source, column=str(dup[0]))
        frame = frame.reset_index(drop=True)

        n = meta.get("n_modules") or _infer_n_modules(list(frame.columns))[0]
        if n:
            # Canonical columns first (also makes Parquet output independent of input order).
            canon = [c for c in column_names(n, truth=True) if c in frame.columns]
            seen = set(canon)
            frame = frame[canon + [c for c in frame.columns if c not in seen]]

        # Numeric schema columns as float64; non-numeric ones are left for validate() to report.
        updates: dict[str, Any] = {}
        for c in frame.columns:
            if c != "t" and _module_index(c) is None:
                continue
            s = frame[c]
            if _is_real_dtype(s.dtype):
                if s.dtype != np.float64:
                    updates[c] = s.astype("float64")
            elif s.dtype == object:
                # Python numbers in an object column (e.g. built from lists with None).
                try:
                    conv = pd.to_numeric(s, errors="raise")
                except (TypeError, ValueError):
                    continue
                if _is_real_dtype(conv.dtype):
                    updates[c] = conv.astype("float64")

        # Trajectory ids are strings (ints written by other programs become "1", "2", ...).
        if "trajectory" in frame.columns:
            tr = frame["trajectory"]
            if not tr.isna().any():
                updates["trajectory"] = tr.astype(str)
        if updates:
            frame = frame.assign(**updates)
        return frame

    def _infer_sample_rate(self) -> float:
        """Sample rate [Hz] from the median positive time step within trajectories."""
        f = self._frame
        try:
            if "t" not in f.columns or "trajectory" not in f.columns or len(f) < 2:
                return DEFAULT_SAMPLE_RATE_HZ
            t = _float_column(f, "t")
            tr = f["trajectory"].to_numpy()
            d = np.diff(t)[tr[1:] == tr[:-1]]
            d = d[np.isfinite(d) & (d > 0)]
            if d.size == 0:
                return DEFAULT_SAMPLE_RATE_HZ
            # 6 significant digits: 9.9999999 Hz from float round-off reads as 10 Hz.
            return float(f"{1.0 / float(np.median(d)):.6g}")
        except (TypeError, ValueError):
            return DEFAULT_SAMPLE_RATE_HZ

    # ---- properties -----------------------------------------------------------------------

    @property
    def frame(self) -> pd.DataFrame:
        """pandas.DataFrame : The data, one row per frame. Treat as read-only."""
        return self._frame

    @property
    def meta(self) -> dict[str, Any]:
        """dict : A copy of the metadata (keys ``schema_version``, ``n_modules``, ...)."""
        return copy.deepcopy(self._meta)

    @property
    def source(self) -> str | None:
        """str or None : The file this recording was read from, named in error messages."""
        return self._source

    @property
    def n_modules(self) -> int:
        """int : Number of modules ``N``."""
        return self._meta["n_modules"]

    @property
    def n_frames(self) -> int:
        """int : Number of frames (rows) ``T``."""
        return len(self._frame)

    def __len__(self) -> int:
        return len(self._frame)

    @property
    def trajectories(self) -> list[str]:
        """list of str : Trajectory ids in order of first appearance."""
        return [str(x) for x in pd.unique(self._frame["trajectory"].to_numpy())]

    @property
    def protocol(self) -> str | None:
        """str or None : The motion protocol (design section 5), if known."""
        return self._meta["protocol"]

    @property
    def sample_rate_hz(self) -> float:
        """float : Sample rate [Hz]."""
        return float(self._meta["sample_rate_hz"])

    @property
    def dt(self) -> float:
        """float : Nominal sample period ``1 / sample_rate_hz`` [s]."""
        return 1.0 / self.sample_rate_hz

    @property
    def time(self) -> np.ndarray:
        """ndarray, shape (T,) : Time within each trajectory [s]."""
        return np.array(_float_column(self._frame, "t"), dtype=np.float64, copy=True)

    @property
    def trajectory_ids(self) -> np.ndarray:
        """ndarray of str, shape (T,) : Trajectory id of every frame."""
        return self._frame["trajectory"].to_numpy().astype(str)

    def _block(self, columns: list[str], shape: tuple[int, ...]) -> np.ndarray:
        a = self._frame[columns].to_numpy(dtype=np.float64, na_value=np.nan)
        return np.ascontiguousarray(a).reshape(shape)

    @property
    def angles(self) -> np.ndarray:
        """ndarray, shape (T, N, 2) : Joint angles [rad]; ``[:, k-1]`` = ``(theta_k_x, theta_k_y)``."""
        n = self.n_modules
        return self._block(_theta_columns(n), (self.n_frames, n, 2))

    @property
    def actuator(self) -> np.ndarray:
        """ndarray, shape (T, N, 3) : Actuator-side tensions ``T[1, j, i]`` [N]; ``[:, j-1, i-1]``."""
        n = self.n_modules
        return self._block(_act_columns(n), (self.n_frames, n, 3))

    @property
    def terminal(self) -> np.ndarray:
        """ndarray, shape (T, 3) : Terminal joint-side tensions ``T[N, N, :]`` [N] (the label)."""
        return self._block(_joint_columns(self.n_modules), (self.n_frames, 3))

    @property
    def has_truth(self) -> bool:
        """bool : True when every intermediate truth column ``tension_joint_{j}_{i}``, j < N, exists."""
        cols = self._frame.columns
        return all(c in cols for c in _truth_columns(self.n_modules))

    @property
    def joint_truth(self) -> np.ndarray | None:
        """ndarray, shape (T, N, 3), or None : Joint-side tensions ``T[j, j, :]`` [N].

        Row ``j-1`` is joint ``j``; ``[:, N-1]`` is the terminal label. None unless all
        intermediate truth columns are present (simulated data only).
        """
        if not self.has_truth:
            return None
        n = self.n_modules
        cols = _truth_columns(n) + _joint_columns(n)
        return self._block(cols, (self.n_frames, n, 3))

    @property
    def trajectory_starts(self) -> np.ndarray:
        """ndarray of bool, shape (T,) : True on the first frame of each trajectory."""
        tr = self._frame["trajectory"].to_numpy()
        starts = np.ones(len(tr), dtype=bool)
        if len(tr) > 1:
            starts[1:] = tr[1:] != tr[:-1]
        return starts

    def _intermediate_joints(self) -> list[int]:
        cols = self._frame.columns
        return [j for j in range(1, self.n_modules)
                if all(c in cols for c in _joint_columns(j))]

    def __repr__(self) -> str:
        src = f", source={self._source!r}" if self._source else ""
        try:
            n_traj = len(self.trajectories)
        except KeyError:
            n_traj = "?"
        truth = self.has_truth if self.n_modules else False
        return (f"Recording(n_modules={self.n_modules}, n_frames={self.n_frames}, "
                f"trajectories={n_traj}, truth={truth}{src})")

    # ---- constructors ----------------------------------------------------------------------

    @classmethod
    def from_arrays(cls, *, trajectory: str | Sequence[str] | np.ndarray, t: np.ndarray,
                    angles: np.ndarray, actuator: np.ndarray, terminal: np.ndarray,
                    joint_truth: np.ndarray | None = None, meta: Mapping[str, Any] | None = None,
                    extra: Mapping[str, np.ndarray] | None = None) -> "Recording":
        """Build a recording from arrays.

        Parameters
        ----------
        trajectory : str or array-like of str, shape (T,)
            Trajectory id of each frame, or one id for all frames.
        t : array-like, shape (T,)
            Time within each trajectory [s].
        angles : array-like, shape (T, N, 2)
            Joint angles [rad].
        actuator : array-like, shape (T, N, 3)
            Actuator-side tensions [N].
        terminal : array-like, shape (T, 3)
            Terminal joint-side tensions [N].
        joint_truth : array-like, shape (T, N, 3) or (T, N-1, 3), optional
            Joint-side truth [N]; row ``j-1`` is joint ``j``. With N rows, the last must equal
            ``terminal``.
        meta : mapping, optional
            Metadata; ``n_modules`` defaults to ``N`` from ``angles``.
        extra : mapping of str to array-like of shape (T,), optional
            Extra columns to carry along.

        Returns
        -------
        Recording
        """
        t = np.asarray(t, dtype=np.float64)
        if t.ndim != 1:
            raise RecordingError(f"t must have shape (T,), got {t.shape}", column="t")
        T = t.shape[0]
        angles = np.asarray(angles, dtype=np.float64)
        if angles.ndim != 3 or angles.shape[0] != T or angles.shape[2] != 2 or angles.shape[1] < 1:
            raise RecordingError(f"angles must have shape (T={T}, N, 2), got {angles.shape}")
        n = angles.shape[1]
        actuator = np.asarray(actuator, dtype=np.float64)
        if actuator.shape != (T, n, 3):
            raise RecordingError(f"actuator must have shape {(T, n, 3)}, got {actuator.shape}")
        terminal = np.asarray(terminal, dtype=np.float64)
        if terminal.shape != (T, 3):
            raise RecordingError(f"terminal must have shape {(T, 3)}, got {terminal.shape}")
        if isinstance(trajectory, str):
            traj = np.full(T, trajectory, dtype=object)
        else:
            traj = np.asarray(trajectory).astype(str).astype(object)
            if traj.shape != (T,):
                raise RecordingError(f"trajectory must have shape {(T,)}, got {traj.shape}",
                                     column="trajectory")

        data: dict[str, np.ndarray] = {"trajectory": traj, "t": t}
        for k in range(n):
            data[f"theta_{k + 1}_x"] = angles[:, k, 0]
            data[f"theta_{k + 1}_y"] = angles[:, k, 1]
        for j in range(n):
            for i in range(3):
                data[f"tension_act_{j + 1}_{i + 1}"] = actuator[:, j, i]
        if joint_truth is not None:
            jt = np.asarray(joint_truth, dtype=np.float64)
            if jt.shape not in ((T, n, 3), (T, n - 1, 3)):
                raise RecordingError(
                    f"joint_truth must have shape {(T, n, 3)} or {(T, n - 1, 3)}, got {jt.shape}")
            if jt.shape[1] == n and not np.array_equal(jt[:, n - 1], terminal, equal_nan=True):
                raise RecordingError("joint_truth[:, N-1] must equal terminal",
                                     column=f"tension_joint_{n}_1")
            for j in range(n - 1):
                for i in range(3):
                    data[f"tension_joint_{j + 1}_{i + 1}"] = jt[:, j, i]
        for i in range(3):
            data[f"tension_joint_{n}_{i + 1}"] = terminal[:, i]
        for name, values in (extra or {}).items():
            name = str(name)
            if name in data:
                raise RecordingError("extra column collides with a schema column", column=name)
            values = np.asarray(values)
            if values.shape != (T,):
                raise RecordingError(f"extra column must have shape {(T,)}, got {values.shape}",
                                     column=name)
            data[name] = values
        meta = dict(meta or {})
        meta.setdefault("n_modules", n)
        return cls(pd.DataFrame(data), meta)

    # ---- IO --------------------------------------------------------------------------------

    @classmethod
    def read(cls, path: str | os.PathLike, *, validate: bool = True) -> "Recording":
        """Read a recording from ``.parquet`` (or ``.pq``) or ``.csv`` (plus sidecar ``.json``).

        Parameters
        ----------
        path : str or path-like
            The file. For CSV, metadata is read from ``path.with_suffix(".json")`` when it
            exists; otherwise ``n_modules`` is inferred from the columns and defaults are used.
        validate : bool, default True
            Validate the data.

        Returns
        -------
        Recording

        Raises
        ------
        RecordingError
            Naming the file, for a missing or unreadable file, an unknown suffix, bad metadata
            or invalid data.
        """
        path = Path(path)
        src = str(path)
        suffix = path.suffix.lower()
        if suffix not in _SUFFIXES_PARQUET + _SUFFIXES_CSV:
            raise RecordingError(
                f"unknown file type '{path.suffix}'; expected .parquet or .csv", file=src)
        if not path.exists():
            raise RecordingError("no such file", file=src)
        if path.is_dir():
            raise RecordingError("is a folder, not a file", file=src)
        if suffix in _SUFFIXES_PARQUET:
            frame, meta = cls._read_parquet(path)
        else:
            frame, meta = cls._read_csv(path)
        return cls(frame, meta, source=src, validate=validate)

    @staticmethod
    def _read_parquet(path: Path) -> tuple[pd.DataFrame, dict[str, Any] | None]:
        import pyarrow as pa
        import pyarrow.parquet as pq

        src = str(path)
        try:
            table = pq.read_table(path)
        except (pa.ArrowException, OSError) as exc:
            raise RecordingError(f"not a readable Parquet file ({_first_line(exc)})",
                                 file=src) from exc
        raw = (table.schema.metadata or {}).get(META_KEY)
        meta = None
        if raw is not None:
            try:
                meta = json.loads(raw.decode("utf-8"))
            except (UnicodeDecodeError, json.JSONDecodeError) as exc:
                raise RecordingError(f"unreadable tendon_id metadata ({_first_line(exc)})",
                                     file=src) from exc
            if not isinstance(meta, dict):
                raise RecordingError("tendon_id metadata is not a JSON object", file=src)
        return table.to_pandas(), meta

    @staticmethod
    def _read_csv(path: Path) -> tuple[pd.DataFrame, dict[str, Any] | None]:
        src = str(path)
        try:
            # Floats written with repr() must read back bit for bit: pandas >= 3 does that by
            # default (and deprecates the option), older pandas needs "round_trip".
            extra = {} if _PANDAS_COW else {"float_precision": "round_trip"}
            frame = pd.read_csv(path, dtype={"trajectory": str}, skipinitialspace=True, **extra)
        except pd.errors.EmptyDataError as exc:
            raise RecordingError("the file is empty", file=src) from exc
        except (pd.errors.ParserError, UnicodeDecodeError, OSError, ValueError) as exc:
            raise RecordingError(f"not a readable CSV file ({_first_line(exc)})",
                                 file=src) from exc
        side = _sidecar(path)
        meta = None
        if side.exists():
            try:
                meta = json.loads(side.read_text(encoding="utf-8"))
            except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
                raise RecordingError(f"unreadable metadata sidecar ({_first_line(exc)})",
                                     file=str(side)) from exc
            if not isinstance(meta, dict):
                raise RecordingError("metadata sidecar is not a JSON object", file=str(side))
        return frame, meta

    def write(self, path: str | os.PathLike) -> Path:
        """Write the recording atomically to ``.parquet`` (or ``.pq``) or ``.csv`` (+ ``.json``).

        Each file is written to a temporary file in the same folder, then renamed over the
        target, so readers never see a partial file. Parquet output is byte-identical for
        identical data and metadata (fixed writer options, no timestamps, no pandas metadata).

        Parameters
        ----------
        path : str or path-like
            Target file; its folder is created if needed. For CSV the metadata goes to
            ``path.with_suffix(".json")``.

        Returns
        -------
        pathlib.Path
            The path written.

        Raises
        ------
        RecordingError
            For an unknown suffix, or data or metadata that cannot be written.
        """
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in _SUFFIXES_PARQUET + _SUFFIXES_CSV:
            raise RecordingError(
                f"unknown file type '{path.suffix}'; expected .parquet or .csv", file=str(path))
        try:
            meta_text = _meta_json(self._meta, indent=2) + "\n"
        except (TypeError, ValueError) as exc:
            raise RecordingError(f"metadata is not JSON serialisable ({_first_line(exc)})",
                                 file=str(path)) from exc
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            if suffix in _SUFFIXES_PARQUET:
                self._write_parquet(path)
            else:
                # Sidecar first: a reader that sees the new CSV also sees its metadata.
                atomic_write(_sidecar(path),
                              lambda tmp: Path(tmp).write_text(meta_text, encoding="utf-8"))
                atomic_write(path, lambda tmp: self._frame.to_csv(
                    tmp, index=False, lineterminator="\n", encoding="utf-8"))
        except OSError as exc:
            raise RecordingError(f"cannot write ({_first_line(exc)})", file=str(path)) from exc
        return path

    def _write_parquet(self, path: Path) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        try:
            table = pa.Table.from_pandas(self._frame, preserve_index=False)
        except (pa.ArrowException, TypeError, ValueError) as exc:
            raise RecordingError(f"cannot convert to Parquet ({_first_line(exc)})",
                                 file=str(path)) from exc
        if "trajectory" in table.column_names:
            # One string type whatever pandas' string storage is (object, python or pyarrow).
            idx = table.column_names.index("trajectory")
            table = table.set_column(idx, "trajectory", table.column(idx).cast(pa.string()))
        # Only our metadata: pandas' block would tie the bytes to the pandas version.
        table = table.replace_schema_metadata(
            {META_KEY: _meta_json(self._meta, separators=(",", ":")).encode("utf-8")})
        atomic_write(path, lambda tmp: pq.write_table(table, tmp, **_PARQUET_OPTIONS))

    # ---- selection -------------------------------------------------------------------------

    def _derive(self, frame: pd.DataFrame, meta: Mapping[str, Any] | None = None) -> "Recording":
        """A recording on a subset of this one's (already validated) data."""
        return Recording(frame, self._meta if meta is None else meta, source=self._source,
                         validate=False)

    def select(self, trajectories: Sequence[str]) -> "Recording":
        """Recording with only the given trajectories, in this recording's row order.

        Parameters
        ----------
        trajectories : sequence of str
            Trajectory ids; each must exist.

        Returns
        -------
        Recording
            Same metadata and source. Rows in its errors refer to the selection.
        """
        if isinstance(trajectories, str):
            trajectories = [trajectories]
        wanted = [str(x) for x in trajectories]
        if not wanted:
            raise RecordingError("cannot select zero trajectories (the recording would be empty)",
                                 file=self._source, column="trajectory")
        have = set(self.trajectories)
        for w in wanted:
            if w not in have:
                raise RecordingError(f"no trajectory '{w}' in this recording",
                                     file=self._source, column="trajectory")
        mask = self._frame["trajectory"].isin(wanted).to_numpy()
        return self._derive(self._frame.loc[mask].reset_index(drop=True))

    def split(self, fractions: Sequence[float] = (0.7, 0.3), *,
              seed: int = 0) -> tuple["Recording", ...]:
        """Split by trajectory, never by frame.

        Trajectories are shuffled with ``numpy.random.default_rng(seed)`` and dealt out in
        proportion to ``fractions`` (largest remainder, at least one trajectory per part).

        Parameters
        ----------
        fractions : sequence of float, default (0.7, 0.3)
            Positive fractions of the trajectories for each part, summing to 1.
        seed : int, default 0
            Seed of the shuffle; the split is deterministic for a seed.

        Returns
        -------
        tuple of Recording
            One per fraction, disjoint in trajectories, each non-empty.

        Raises
        ------
        RecordingError
            When there are fewer trajectories than parts.
        ConfigError
            For fractions that are not positive or do not sum to 1.
        """
        f = np.asarray(list(fractions), dtype=np.float64)
        if f.ndim != 1 or f.size < 1 or not np.all(np.isfinite(f)) or np.any(f <= 0) \
                or abs(f.sum() - 1.0) > 1e-6:
            raise ConfigError(f"split fractions must be positive and sum to 1, got {list(fractions)}")
        ids = self.trajectories
        n, parts = len(ids), f.size
        if n < parts:
            raise RecordingError(
                f"cannot split {n} trajectories into {parts} non-empty parts; "
                "splits are made by trajectory, never by frame",
                file=self._source, column="trajectory")
        raw = f * n
        counts = np.maximum(1, np.floor(raw)).astype(int)
        while counts.sum() < n:
            counts[int(np.argmax(raw - counts))] += 1
        while counts.sum() > n:
            over = np.where(counts > 1, counts - raw, -np.inf)
            counts[int(np.argmax(over))] -= 1
        order = np.random.default_rng(seed).permutation(n)
        bounds = np.concatenate([[0], np.cumsum(counts)])
        return tuple(self.select([ids[i] for i in sorted(order[bounds[p]:bounds[p + 1]])])
                     for p in range(parts))

    @staticmethod
    def concat(recordings: Sequence["Recording"]) -> "Recording":
        """Stack recordings of the same robot size.

        Intermediate truth columns are kept only where every input has them; extra columns
        missing from some inputs are filled with NaN. Metadata comes from the first input;
        ``protocol``, ``recipe``, ``seed`` and ``robot`` become None where the inputs differ, and
        ``effects`` is the union in order of first appearance.

        Parameters
        ----------
        recordings : sequence of Recording
            Same ``n_modules`` and ``sample_rate_hz``; trajectory ids must not collide.

        Returns
        -------
        Recording

        Raises
        ------
        RecordingError
            For an empty sequence, different ``n_modules`` or sample rates, or a trajectory id
            that appears in two inputs.
        """
        recs = list(recordings)
        if not recs:
            raise RecordingError("cannot concatenate zero recordings")
        first = recs[0]
        n = first.n_modules
        seen: dict[str, str | None] = {}
        for r in recs:
            if not isinstance(r, Recording):
                raise TypeError(f"expected Recording, got {type(r).__name__}")
            if r.n_modules != n:
                raise RecordingError(
                    f"cannot concatenate recordings with {n} and {r.n_modules} modules",
                    file=r.source)
            if not math.isclose(r.sample_rate_hz, first.sample_rate_hz, rel_tol=1e-9):
                raise RecordingError(
                    f"cannot concatenate recordings sampled at {first.sample_rate_hz} Hz and "
                    f"{r.sample_rate_hz} Hz", file=r.source)
            for tid in r.trajectories:
                if tid in seen:
                    where = seen[tid] or "another recording"
                    raise RecordingError(
                        f"trajectory id '{tid}' appears in {where} too; rename one",
                        file=r.source, column="trajectory")
                seen[tid] = r.source
        truth = [c for c in _truth_columns(n) if all(c in r.frame.columns for r in recs)]
        drop = set(_truth_columns(n)) - set(truth)
        frames = [r.frame.drop(columns=[c for c in r.frame.columns if c in drop]) for r in recs]
        frame = pd.concat(frames, axis=0, ignore_index=True, sort=False)

        meta = first.meta
        for key in ("protocol", "recipe", "seed", "robot"):
            if any(r._meta[key] != meta[key] for r in recs[1:]):
                meta[key] = None
        effects: list[str] = []
        for r in recs:
            effects += [e for e in r._meta["effects"] if e not in effects]
        meta["effects"] = effects
        return Recording(frame, meta)

    def fitting_view(self) -> "Recording":
        """A copy without the intermediate truth columns, for a model's ``fit``.

        Every ``tension_joint_{j}_{i}`` with ``j < N`` is removed, so code handed this view is
        structurally unable to read intermediate ground truth (``has_truth`` is False,
        ``joint_truth`` is None). The terminal label ``tension_joint_{N}_{i}`` is kept.

        Returns
        -------
        Recording
        """
        hidden = [c for c in self._frame.columns
                  if (m := _TENSION_RE.match(c)) and m.group(1) == "joint"
                  and int(m.group(2)) < self.n_modules]
        return self._derive(self._frame.drop(columns=hidden))

    def with_meta(self, **updates: Any) -> "Recording":
        """A recording with the same data and some metadata keys replaced.

        Parameters
        ----------
        **updates
            Metadata keys and their new values.

        Returns
        -------
        Recording
        """
        meta = self.meta
        meta.update(updates)
        return Recording(self._frame, meta, source=self._source,
                         validate="n_modules" in updates)

    # ---- validation ------------------------------------------------------------------------

    def _error(self, reason: str, column: str | None = None, row: int | None = None):
        return RecordingError(reason, file=self._source, column=column, row=row)

    def validate(self) -> None:
        """Check the recording against the schema; raise on the first problem.

        Checks, in order: empty recording; duplicate, missing or inconsistently numbered
        columns and a ``n_modules`` that does not match them; non-numeric values; missing or
        empty trajectory ids; a trajectory split into non-contiguous blocks; NaN or inf values;
        non-positive tensions; angles that look like degrees (``|angle| > pi``); time that does
        not strictly increase within a trajectory. Checks are vectorised (per column).

        Raises
        ------
        RecordingError
            Naming the file, the column and the 0-based frame row of the first offending value.
        """
        f = self._frame
        if len(f) == 0:
            raise self._error("the recording is empty (no frames)")
        n = self._check_columns()
        cols = _required_columns(n)
        numeric = [c for c in cols if c != "trajectory"]
        numeric += [c for c in _truth_columns(n) if c in f.columns]
        tensions = [c for c in numeric if c.startswith("tension_")]
        thetas = _theta_columns(n)

        # Non-numeric data.
        for c in numeric:
            s = f[c]
            if not _is_real_dtype(s.dtype):
                coerced = pd.to_numeric(s, errors="coerce") if s.dtype.kind in ("O", "U", "S", "T") \
                    or pd.api.types.is_string_dtype(s.dtype) else pd.Series(np.nan, index=s.index)
                bad = (coerced.isna() & s.notna()).to_numpy()
                row = _first_true(bad)
                value = f" {_short(s.iloc[row])}" if row is not None else ""
                raise self._error(f"non-numeric value{value} (dtype {s.dtype}); expected numbers",
                                  c, row)

        # Trajectory ids.
        tr = f["trajectory"]
        row = _first_true(tr.isna().to_numpy())
        if row is not None:
            raise self._error("missing trajectory id", "trajectory", row)
        ids = tr.to_numpy().astype(str)
        row = _first_true(np.char.str_len(ids) == 0) if ids.dtype.kind == "U" else None
        if row is not None:
            raise self._error("empty trajectory id", "trajectory", row)
        starts = np.ones(len(ids), dtype=bool)
        starts[1:] = ids[1:] != ids[:-1]
        start_rows = np.flatnonzero(starts)
        block_ids = pd.Series(ids[start_rows])
        dup = block_ids.duplicated().to_numpy()
        if dup.any():
            b = int(dup.argmax())
            raise self._error(
                f"trajectory '{block_ids.iloc[b]}' appears in two separate blocks of rows; "
                "each trajectory must be one contiguous block", "trajectory", int(start_rows[b]))

        # Finite values, positive tensions, angles in rad: report the earliest row, then the
        # first column in canonical order.
        arrays = {c: _float_column(f, c) for c in numeric}
        hit = self._first_hit(numeric, arrays, lambda a: ~np.isfinite(a))
        if hit:
            c, row = hit
            v = arrays[c][row]
            raise self._error("NaN value" if np.isnan(v) else f"infinite value ({v})", c, row)
        hit = self._first_hit(tensions, arrays, lambda a: a <= 0)
        if hit:
            c, row = hit
            raise self._error(f"non-positive tension {arrays[c][row]:g} N; tensions must be > 0 N",
                              c, row)
        hit = self._first_hit(thetas, arrays, lambda a: np.abs(a) > np.pi)
        if hit:
            c, row = hit
            raise self._error(f"|angle| = {abs(arrays[c][row]):g} > pi looks like degrees; "
                              "angles must be in rad", c, row)

        # Time strictly increasing within each trajectory.
        t = arrays["t"]
        bad = np.zeros(len(t), dtype=bool)
        bad[1:] = (np.diff(t) <= 0) & ~starts[1:]
        row = _first_true(bad)
        if row is not None:
            raise self._error(
                f"time does not increase within trajectory '{ids[row]}' "
                f"(t = {t[row]:g} s after {t[row - 1]:g} s)", "t", row)

    @staticmethod
    def _first_hit(columns: list[str], arrays: Mapping[str, np.ndarray],
                   test) -> tuple[str, int] | None:
        best: tuple[str, int] | None = None
        for c in columns:
            row = _first_true(test(arrays[c]))
            if row is not None and (best is None or row < best[1]):
                best = (c, row)
                if row == 0:
                    break
        return best

    def _check_columns(self) -> int:
        """Check columns against the schema and ``n_modules``; return ``N``."""
        cols = list(self._frame.columns)
        for c in cols:
            m = _THETA_RE.match(c)
            k = int(m.group(1)) if m else None
            m2 = _TENSION_RE.match(c)
            if m2:
                k = int(m2.group(2))
                if int(m2.group(3)) not in _TENDONS:
                    raise self._error(
                        "inconsistent numbering: tendons are numbered 1..3", c)
            if k == 0:
                raise self._error("inconsistent numbering: modules are numbered from 1", c)
        inferred, by = _infer_n_modules(cols)
        n = self._meta["n_modules"]
        if inferred is None:
            missing = "trajectory" if "trajectory" not in cols else \
                "t" if "t" not in cols else "theta_1_x"
            raise self._error("missing required column; no theta_/tension_ columns found, so "
                              "the number of modules cannot be inferred", missing)
        if n is None:
            n = inferred
        if n != inferred:
            if inferred > n:
                column = next((c for c in column_names(inferred) if c in cols
                               and (_module_index(c) or 0) > n), by)
            else:
                column = next(c for c in _required_columns(n) if c not in cols)
            raise self._error(f"n_modules is {n} in the metadata but the columns describe "
                              f"{inferred} modules", column)
        for c in _required_columns(n):
            if c not in cols:
                why = "" if c in ("trajectory", "t") else f" (n_modules is {n})"
                raise self._error(f"missing required column{why}", c)
        return n

    def check_history_window(self, h: int) -> None:
        """Check that every trajectory has at least ``h`` frames.

        Parameters
        ----------
        h : int
            History window of a learned model [frames].

        Raises
        ------
        RecordingError
            Naming the first too-short trajectory (row: its first frame).
        """
        if not _is_int(h) or h < 1:
            raise ConfigError(f"history window must be a positive integer, got {h!r}")
        starts = np.flatnonzero(self.trajectory_starts)
        lengths = np.diff(np.append(starts, self.n_frames))
        short = np.flatnonzero(lengths < h)
        if short.size:
            s = int(short[0])
            tid = str(self._frame["trajectory"].iloc[int(starts[s])])
            raise self._error(
                f"trajectory '{tid}' has {int(lengths[s])} frames, fewer than the history "
                f"window of {int(h)} frames", "trajectory", int(starts[s]))

    # ---- summary ---------------------------------------------------------------------------

    def summary(self) -> dict[str, Any]:
        """A JSON-serialisable summary, for ``tendon-id info``.

        Returns
        -------
        dict
            ``n_modules``, ``n_frames``, ``n_trajectories``, ``trajectories`` (id -> frames),
            ``duration_s`` (sum over trajectories of last minus first time plus ``dt`` [s]),
            ``protocol``, ``sample_rate_hz``, ``ranges`` (``{"min", "max"}`` of ``angle_rad``,
            ``angle_deg``, ``actuator_n``, ``terminal_n``), ``truth`` (``terminal``: True,
            ``intermediate``: all intermediate truth present, ``intermediate_joints``: the
            joints ``j < N`` whose truth is present), ``effects``, ``recipe``, ``seed``,
            ``source``.
        """
        starts = np.flatnonzero(self.trajectory_starts)
        ends = np.append(starts[1:], self.n_frames) - 1
        lengths = ends - starts + 1
        t = self.time
        duration = float(np.sum(t[ends] - t[starts]) + len(starts) * self.dt)
        ids = self._frame["trajectory"].to_numpy()

        def rng(a: np.ndarray) -> dict[str, float]:
            return {"min": float(np.min(a)), "max": float(np.max(a))}

        angles = self.angles
        joints = self._intermediate_joints()
        return {
            "n_modules": self.n_modules,
            "n_frames": self.n_frames,
            "n_trajectories": int(len(starts)),
            "trajectories": {str(ids[s]): int(n) for s, n in zip(starts, lengths)},
            "duration_s": duration,
            "protocol": self.protocol,
            "sample_rate_hz": self.sample_rate_hz,
            "ranges": {
                "angle_rad": rng(angles),
                "angle_deg": rng(np.degrees(angles)),
                "actuator_n": rng(self.actuator),
                "terminal_n": rng(self.terminal),
            },
            "truth": {
                "terminal": True,
                "intermediate": len(joints) == self.n_modules - 1,
                "intermediate_joints": joints,
            },
            "effects": list(self._meta["effects"]),
            "recipe": self._meta["recipe"],
            "seed": self._meta["seed"],
            "source": self._source,
        }


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text else type(exc).__name__
