"""Bring user input into the canonical form of a snake recording (:doc:`/guide/data`).

:func:`normalise_meta` checks the types of the known metadata keys and fills defaults;
:func:`normalise_frame` copies a DataFrame, puts the canonical columns first and converts
the schema columns to their canonical dtypes. Neither judges the data itself: that is
:mod:`tendon_id.data.validation`.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from tendon_id.data.columns import PANDAS_COW, is_int, is_real_dtype
from tendon_id.data.schema import SCHEMA_VERSION, column_names, infer_n_modules, module_index, tendon_count
from tendon_id.errors import RecordingError

__all__ = ["normalise_frame", "normalise_meta"]


def _numbers(v: Any) -> bool:
    """True for a finite real number (not a bool), or a (nested) list of them."""
    if isinstance(v, (list, tuple)):
        return all(_numbers(x) for x in v)
    if isinstance(v, (bool, np.bool_)):
        return False
    if is_int(v):
        return True  # Python ints may be too large for a float, and are finite anyway
    return isinstance(v, (float, np.floating)) and math.isfinite(v)


def normalise_meta(meta: Mapping[str, Any] | None, source: str | None) -> dict[str, Any]:
    """Check the types of the known metadata keys and fill defaults (n_modules may stay None).

    Parameters
    ----------
    meta : mapping or None
        The metadata as given; None means no metadata.
    source : str or None
        File the metadata came from, named in errors.

    Returns
    -------
    dict
        The known keys with plain Python values (``sample_rate_hz`` and ``n_modules`` may be
        None, for the caller to infer), then any unknown keys, deep-copied.

    Raises
    ------
    RecordingError
        For a value of the wrong type (including a ``robot`` value that is not a finite number or
        a list of them), or a schema version newer than this package.
    """
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
    if not is_int(version) or version < 1:
        raise bad("schema_version", "a positive integer")
    if version > SCHEMA_VERSION:
        raise RecordingError(
            f"schema_version {version} is newer than this tendon-id understands ({SCHEMA_VERSION}); upgrade tendon-id",
            file=source,
        )
    out["schema_version"] = int(version)

    n = raw.get("n_modules")
    if n is not None and (not is_int(n) or n < 1):
        raise bad("n_modules", "a positive integer")
    out["n_modules"] = None if n is None else int(n)

    rate = raw.get("sample_rate_hz")
    if rate is not None:
        if (
            isinstance(rate, (bool, np.bool_))
            or not isinstance(rate, (int, float, np.number))
            or not math.isfinite(float(rate))
            or float(rate) <= 0
        ):
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
    for key, v in (robot or {}).items():
        # Robot geometry is numbers [m, rad]; a text or null value would only fail later, deep in a fit.
        if not _numbers(v):
            raise RecordingError(
                f"metadata 'robot.{key}' must be a finite number or a list of them, got {v!r}", file=source
            )
    out["robot"] = None if robot is None else copy.deepcopy(dict(robot))

    sensors = raw.get("sensors")
    if sensors is not None and not isinstance(sensors, Mapping):
        raise bad("sensors", "a mapping or null")
    for key in ("noise_n", "range_n"):  # load-cell noise and range [N]: the analyses weight data by them
        v = (sensors or {}).get(key)
        if v is not None and not (_numbers(v) and not isinstance(v, (list, tuple)) and 0 <= v < math.inf):
            raise RecordingError(f"metadata 'sensors.{key}' must be a non-negative number of N, got {v!r}", file=source)

    effects = raw.get("effects")
    if effects is None:
        effects = []
    elif isinstance(effects, str):
        # "a,b" as the CLI writes it; "none" or "" means no effect.
        effects = (
            [] if effects.strip().lower() in ("", "none") else [e.strip() for e in effects.split(",") if e.strip()]
        )
    if not isinstance(effects, (list, tuple)) or not all(isinstance(e, str) for e in effects):
        raise bad("effects", "a list of effect names")
    out["effects"] = list(effects)

    seed = raw.get("seed")
    if seed is not None and not is_int(seed):
        raise bad("seed", "an integer or null")
    out["seed"] = None if seed is None else int(seed)

    # Unknown keys are kept (forward compatibility, user annotations).
    for key, v in raw.items():
        if key not in out:
            out[str(key)] = copy.deepcopy(v)
    return out


def normalise_frame(frame: pd.DataFrame, meta: Mapping[str, Any], source: str | None) -> pd.DataFrame:
    """A copy of ``frame`` in canonical form.

    Parameters
    ----------
    frame : pandas.DataFrame
        One row per frame, as given.
    meta : mapping
        Normalised metadata (see :func:`normalise_meta`); only ``n_modules`` and ``robot.n_tendons`` are read.
    source : str or None
        File the data came from, named in errors.

    Returns
    -------
    pandas.DataFrame
        Column names as str, a fresh RangeIndex, the canonical columns first (in the order of
        :func:`~tendon_id.data.schema.column_names`), ``t`` and the module-numbered columns as
        float64 where their values are numbers, and ``trajectory`` as str unless it has
        missing values (left for validation to report).

    Raises
    ------
    RecordingError
        For a duplicate column name.
    """
    # Under copy-on-write (pandas >= 3) a shallow copy is already safe from later edits of
    # the caller's frame; before that, copy the data.
    frame = frame.copy(deep=not PANDAS_COW)
    frame.columns = [str(c) for c in frame.columns]
    dup = frame.columns[frame.columns.duplicated()]
    if len(dup):
        raise RecordingError("duplicate column", file=source, column=str(dup[0]))
    frame = frame.reset_index(drop=True)

    # The columns bound N: metadata that claims more modules (10**6, a typo) is refused by
    # validation, and is never used to size anything before (that would cost O(claimed N)).
    inferred = infer_n_modules(list(frame.columns))[0]
    n = min(meta["n_modules"], inferred) if meta.get("n_modules") and inferred else inferred
    if n and (meta.get("robot") or {}).get("bending_axes") == 1:
        # A hinge has no second axis: a planar robot's log may leave theta_k_y out, and it is zero.
        missing = {f"theta_{k}_y": 0.0 for k in range(1, n + 1) if f"theta_{k}_y" not in frame.columns}
        frame = frame.assign(**missing) if missing else frame
    if n:
        # Canonical columns first (also makes Parquet output independent of input order).
        n_tendons = tendon_count(meta.get("robot"), list(frame.columns))
        canon = [c for c in column_names(n, truth=True, n_tendons=n_tendons) if c in frame.columns]
        seen = set(canon)
        frame = frame[canon + [c for c in frame.columns if c not in seen]]

    # Numeric schema columns as float64; non-numeric ones are left for validate() to report.
    updates: dict[str, Any] = {}
    for c in frame.columns:
        if c != "t" and module_index(c) is None:
            continue
        s = frame[c]
        if is_real_dtype(s.dtype):
            if s.dtype != np.float64:
                updates[c] = s.astype("float64")
        elif s.dtype == object:
            # Python numbers in an object column (e.g. built from lists with None).
            try:
                conv = pd.to_numeric(s, errors="raise")
            except (TypeError, ValueError):
                continue
            if is_real_dtype(conv.dtype):
                updates[c] = conv.astype("float64")

    # Trajectory ids are strings (ints written by other programs become "1", "2", ...).
    if "trajectory" in frame.columns:
        tr = frame["trajectory"]
        if not tr.isna().any():
            updates["trajectory"] = tr.astype(str)
    if updates:
        frame = frame.assign(**updates)
    return frame
