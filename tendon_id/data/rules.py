"""The rules every recording's data must keep, whatever its family: one small function per rule.

Each ``check_*`` function raises :class:`~tendon_id.errors.RecordingError` naming the file
(``source``), the column and the 0-based frame row of the first offending value, and returns
nothing (or the value it had to compute anyway). Checks are vectorised per column. A family's
recording composes them with its own (the snake chain's: :mod:`tendon_id.data.validation`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from tendon_id.data.columns import is_real_dtype
from tendon_id.errors import RecordingError

__all__ = [
    "trajectory_starts",
    "check_not_empty",
    "check_numeric",
    "trajectory_codes",
    "check_trajectory_ids",
    "check_contiguous_trajectories",
    "check_finite",
    "check_representable",
    "SAFE_MAGNITUDE",
    "check_positive_tensions",
    "check_time_increases",
    "first_hit",
    "first_true",
]


#: Frames a per-frame check looks at at once (bounded temporaries on hour-long logs).
CHECK_SLICE = 1 << 18


def first_true(mask: np.ndarray) -> int | None:
    if mask.size and mask.any():
        return int(mask.argmax())
    return None


def _short(value: Any, width: int = 40) -> str:
    r = repr(value)
    return r if len(r) <= width else r[: width - 3] + "..."


def first_hit(arrays: Mapping[str, np.ndarray], test: Callable[[np.ndarray], np.ndarray]) -> tuple[str, int] | None:
    """Earliest row where ``test`` holds, then the first such column in the mapping's order.

    ``test`` sees :data:`CHECK_SLICE` rows at a time, so its temporaries stay small on long logs.
    """
    n = max((len(a) for a in arrays.values()), default=0)
    for a0 in range(0, n, CHECK_SLICE):
        best: tuple[str, int] | None = None
        for c, a in arrays.items():
            row = first_true(test(a[a0 : a0 + CHECK_SLICE]))
            if row is not None and (best is None or a0 + row < best[1]):
                best = (c, a0 + row)
        if best is not None:
            return best
    return None


def trajectory_starts(ids: np.ndarray) -> np.ndarray:
    """ndarray of bool, shape (T,): True on the first frame of each block of equal ``ids``."""
    starts = np.ones(len(ids), dtype=bool)
    if len(ids) > 1:
        starts[1:] = ids[1:] != ids[:-1]
    return starts


def check_not_empty(frame: pd.DataFrame, *, source: str | None = None) -> None:
    """Raise when the recording has no frames."""
    if len(frame) == 0:
        raise RecordingError("the recording is empty (no frames)", file=source)


def check_numeric(frame: pd.DataFrame, columns: Sequence[str], *, source: str | None = None) -> None:
    """Raise for the first of ``columns`` whose dtype is not integer or floating.

    The row named is the first value that does not parse as a number; for a text column whose
    values all parse, the first missing value, else None (numbers stored as text). Booleans are
    not numbers: the row is the first value.
    """
    for c in columns:
        s = frame[c]
        if not is_real_dtype(s.dtype):
            text = s.dtype.kind in ("O", "U", "S", "T") or pd.api.types.is_string_dtype(s.dtype)
            coerced = pd.to_numeric(s, errors="coerce") if text else pd.Series(np.nan, index=s.index)
            bad = (coerced.isna() & s.notna()).to_numpy()
            row = first_true(bad)
            if row is not None:
                v = s.iloc[row]
                shown = _short(v.item() if isinstance(v, np.generic) else v)
                reason = f"non-numeric value {shown} (dtype {s.dtype}); expected numbers"
            else:
                row = first_true(s.isna().to_numpy())
                if row is not None:
                    reason = f"missing value in a column of text (dtype {s.dtype}); expected numbers"
                else:
                    reason = f"numbers stored as text (dtype {s.dtype}); expected a numeric column"
            raise RecordingError(reason, file=source, column=c, row=row)


def trajectory_codes(frame: pd.DataFrame, *, source: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Raise for a missing or empty trajectory id; return each frame's id as a code, and the ids.

    Codes, not a str array per frame: on 3.6·10^6 frames the latter is a Python string per frame
    and a fixed-width copy of them, a third of the float64 data of a 12-module recording.

    Returns
    -------
    codes : ndarray of int, shape (T,)
        ``names[codes]`` is :func:`check_trajectory_ids`' array; equal codes, equal ids.
    names : ndarray of str, shape (number of distinct ids,)
    """
    tr = frame["trajectory"]
    codes, uniques = pd.factorize(tr)  # a missing id gets the code -1
    row = first_true(codes < 0)
    if row is not None:
        raise RecordingError("missing trajectory id", file=source, column="trajectory", row=row)
    names = np.asarray(uniques).astype(str)
    empty = np.flatnonzero(np.char.str_len(names) == 0) if names.size else []
    if len(empty):
        row = first_true(codes == empty[0])
        raise RecordingError("empty trajectory id", file=source, column="trajectory", row=row)
    return codes, names


def check_trajectory_ids(frame: pd.DataFrame, *, source: str | None = None) -> np.ndarray:
    """Raise for a missing or empty trajectory id; return the ids as a str array, shape (T,).

    :func:`trajectory_codes` checks the same with far less memory.
    """
    codes, names = trajectory_codes(frame, source=source)
    return names[codes]


def _named(ids: np.ndarray, names: np.ndarray | None, at) -> Any:
    """The id of ``ids[at]``: itself, or where ``ids`` are codes, its name."""
    return ids[at] if names is None else names[ids[at]]


def check_contiguous_trajectories(
    ids: np.ndarray, *, source: str | None = None, names: np.ndarray | None = None
) -> None:
    """Raise when a trajectory id appears in two separate blocks of rows (row: the second block).

    ``ids`` may be the codes of :func:`trajectory_codes`, with its ``names``.
    """
    start_rows = np.flatnonzero(trajectory_starts(ids))
    block_ids = pd.Series(_named(ids, names, start_rows))
    dup = block_ids.duplicated().to_numpy()
    if dup.any():
        b = int(dup.argmax())
        raise RecordingError(
            f"trajectory '{block_ids.iloc[b]}' appears in two separate blocks of rows; "
            "each trajectory must be one contiguous block",
            file=source,
            column="trajectory",
            row=int(start_rows[b]),
        )


def check_finite(arrays: Mapping[str, np.ndarray], *, source: str | None = None) -> None:
    """Raise for a NaN or inf value in any of the float64 ``arrays`` (column name -> values).

    The earliest row is reported, then the first column in the mapping's order.
    """
    hit = first_hit(arrays, lambda a: ~np.isfinite(a))
    if hit:
        c, row = hit
        v = arrays[c][row]
        raise RecordingError("NaN value" if np.isnan(v) else f"infinite value ({v})", file=source, column=c, row=row)


#: Largest magnitude a recording's value may have. Every fit and metric squares its values or
#: multiplies two of them; beyond 1e150 a square or a sum of 10^7 squares overflows float64's
#: 1.8e308, and the result is inf or NaN instead of an error (IEEE 754-2008, section 3.2).
SAFE_MAGNITUDE = 1.0e150


def check_representable(arrays: Mapping[str, np.ndarray], *, source: str | None = None) -> None:
    """Raise for a value whose arithmetic leaves float64's normal range, in any of the finite float64 ``arrays``.

    A magnitude above :data:`SAFE_MAGNITUDE` overflows once squared; a subnormal one (non-zero,
    below 2.2e-308) has lost its precision already and underflows to zero once squared. Either
    would turn a fit or a metric into NaN; here it is one line naming the file, column and row.
    Run after :func:`check_finite`.
    """
    tiny = np.finfo(np.float64).tiny

    def bad(a):
        m = np.abs(a)
        return (m > SAFE_MAGNITUDE) | ((m < tiny) & (m > 0))

    hit = first_hit(arrays, bad)
    if hit:
        c, row = hit
        v = float(arrays[c][row])
        why = (
            f"beyond +-{SAFE_MAGNITUDE:g}, where its square overflows float64"
            if abs(v) > SAFE_MAGNITUDE
            else "subnormal (below 2.2e-308), where float64 has lost its precision"
        )
        raise RecordingError(f"value {v:g} is {why}; check the unit and scale", file=source, column=c, row=row)


def check_positive_tensions(arrays: Mapping[str, np.ndarray], *, source: str | None = None) -> None:
    """Raise for a tension <= 0 N in any of the float64 tension ``arrays`` [N] (earliest row first)."""
    hit = first_hit(arrays, lambda a: a <= 0)
    if hit:
        c, row = hit
        raise RecordingError(
            f"non-positive tension {arrays[c][row]:g} N; tensions must be > 0 N", file=source, column=c, row=row
        )


#: Range of tensions a recording may hold [N]. A snake robot's tendons carry tens to hundreds of N
#: and no load cell resolves a nN; a value outside is a unit or storage error, and its square
#: overflows or underflows in the metrics.
def check_time_increases(
    t: np.ndarray, ids: np.ndarray, *, source: str | None = None, names: np.ndarray | None = None
) -> None:
    """Raise where time [s] does not strictly increase within a trajectory.

    Parameters
    ----------
    t : ndarray, shape (T,)
        Time [s], float64.
    ids : ndarray, shape (T,)
        Trajectory id of every frame (or its code, with ``names``); time may restart where the id changes.
    source : str, optional
        File named in the error.
    names : ndarray of str, optional
        The ids, where ``ids`` are the codes of :func:`trajectory_codes`.
    """
    starts = trajectory_starts(ids)
    row = None
    # In slices: whole-length temporaries would be a tenth of a 12-module recording each.
    for a in range(1, len(t), CHECK_SLICE):
        b = min(a + CHECK_SLICE, len(t))
        hit = first_true((t[a:b] <= t[a - 1 : b - 1]) & ~starts[a:b])
        if hit is not None:
            row = a + hit
            break
    if row is not None:
        raise RecordingError(
            f"time does not increase within trajectory '{_named(ids, names, row)}' "
            f"(t = {t[row]:g} s after {t[row - 1]:g} s)",
            file=source,
            column="t",
            row=row,
        )
