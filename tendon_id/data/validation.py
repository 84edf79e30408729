"""Input validation of a snake recording (:doc:`/guide/data`): its own rules, and all of them in order.

The rules every recording keeps are :mod:`tendon_id.data.rules`. Each ``check_*`` function raises
:class:`~tendon_id.errors.RecordingError` naming the file
(``source``), the column and the 0-based frame row of the first offending value, and returns
nothing (or the value it had to compute anyway). :func:`validate` runs them in order, so the
first problem in that order is the one reported. Checks are vectorised per column.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from tendon_id.data.columns import float_column, is_int
from tendon_id.data.rules import (
    check_contiguous_trajectories,
    check_finite,
    check_not_empty,
    check_numeric,
    check_positive_tensions,
    check_representable,
    check_time_increases,
    first_hit,
    trajectory_codes,
    trajectory_starts,
)
from tendon_id.data.schema import (
    TENSION_RE,
    THETA_RE,
    column_names,
    infer_n_modules,
    module_index,
    required_columns,
    tendon_count,
    theta_columns,
    truth_columns,
)
from tendon_id.errors import ConfigError, RecordingError

__all__ = [
    "check_numbering",
    "check_n_modules",
    "check_required_columns",
    "MIN_TENSION_N",
    "MAX_TENSION_N",
    "check_tension_magnitude",
    "check_angles_in_rad",
    "check_history_window",
    "check_robot_meta",
    "check_planar",
    "validate",
]


def check_numbering(columns: Sequence[str], n_tendons: int = 3, *, source: str | None = None) -> None:
    """Raise for a schema column numbered from 0 or with a tendon outside ``1..n_tendons``."""
    for c in columns:
        m = THETA_RE.match(c)
        k = int(m.group(1)) if m else None
        m2 = TENSION_RE.match(c)
        if m2:
            k = int(m2.group(2))
            if not 1 <= int(m2.group(3)) <= n_tendons:
                raise RecordingError(
                    f"inconsistent numbering: tendons are numbered 1..{n_tendons} (robot.n_tendons = {n_tendons})",
                    file=source,
                    column=c,
                )
        if k == 0:
            raise RecordingError("inconsistent numbering: modules are numbered from 1", file=source, column=c)


def check_n_modules(columns: Sequence[str], n_modules: int | None, *, source: str | None = None) -> int:
    """Check that ``n_modules`` matches the columns; return ``N``.

    Parameters
    ----------
    columns : sequence of str
        Column names of the recording.
    n_modules : int or None
        ``N`` from the metadata; None takes it from the columns.
    source : str, optional
        File named in the error.

    Returns
    -------
    int
        The number of modules ``N``.

    Raises
    ------
    RecordingError
        When no module-numbered column exists, or the largest module index among the columns
        differs from ``n_modules`` (naming the first column beyond ``N``, or the first required
        column missing).
    """
    cols = list(columns)
    inferred, by = infer_n_modules(cols)
    n = n_modules
    if inferred is None:
        missing = "trajectory" if "trajectory" not in cols else "t" if "t" not in cols else "theta_1_x"
        raise RecordingError(
            "missing required column; no theta_/tension_ columns found, so the number of modules cannot be inferred",
            file=source,
            column=missing,
        )
    if n is None:
        n = inferred
    if n != inferred:
        if inferred > n:
            column = next((c for c in column_names(inferred) if c in cols and (module_index(c) or 0) > n), by)
        else:
            # The first column of module inferred + 1 is missing; listing all n modules' would cost
            # O(n) however large the metadata's n (a 10**30 there is a typo, not a robot).
            column = next(c for c in required_columns(inferred + 1) if c not in cols)
        raise RecordingError(
            f"n_modules is {n} in the metadata but the columns describe {inferred} modules", file=source, column=column
        )
    return n


def check_required_columns(
    columns: Sequence[str], n_modules: int, n_tendons: int = 3, *, source: str | None = None
) -> None:
    """Raise for the first required column (see :func:`required_columns`) that is missing.

    Extra columns are fine: they are kept and ignored.
    """
    cols = list(columns)
    for c in required_columns(n_modules, n_tendons):
        if c not in cols:
            why = "" if c in ("trajectory", "t") else f" (n_modules is {n_modules})"
            raise RecordingError(f"missing required column{why}", file=source, column=c)


MIN_TENSION_N, MAX_TENSION_N = 1.0e-9, 1.0e6


def check_tension_magnitude(arrays: Mapping[str, np.ndarray], *, source: str | None = None) -> None:
    """Raise for a positive tension outside [:data:`MIN_TENSION_N`, :data:`MAX_TENSION_N`] [N].

    Run after :func:`check_positive_tensions`; ``arrays`` are the float64 tension columns.
    """
    hit = first_hit(arrays, lambda a: (a < MIN_TENSION_N) | (a > MAX_TENSION_N))
    if hit:
        c, row = hit
        v = arrays[c][row]
        bound = f"> {MAX_TENSION_N:g} N" if v > MAX_TENSION_N else f"< {MIN_TENSION_N:g} N"
        raise RecordingError(
            f"tension {v:g} N is implausibly {'large' if v > MAX_TENSION_N else 'small'} ({bound}); "
            "tensions must be in N",
            file=source,
            column=c,
            row=row,
        )


def check_angles_in_rad(arrays: Mapping[str, np.ndarray], *, source: str | None = None) -> None:
    """Raise for ``|angle| > pi`` in any of the float64 angle ``arrays`` [rad]: likely degrees."""
    hit = first_hit(arrays, lambda a: np.abs(a) > np.pi)
    if hit:
        c, row = hit
        raise RecordingError(
            f"|angle| = {abs(arrays[c][row]):g} > pi looks like degrees; angles must be in rad",
            file=source,
            column=c,
            row=row,
        )


def check_planar(frame: pd.DataFrame, n_modules: int, *, source: str | None = None) -> None:
    """Raise for a nonzero ``theta_k_y`` of a planar robot (``robot.bending_axes = 1``): a hinge bends towards x."""
    arrays = {f"theta_{k}_y": float_column(frame, f"theta_{k}_y") for k in range(1, n_modules + 1)}
    hit = first_hit(arrays, lambda a: a != 0.0)
    if hit:
        c, row = hit
        raise RecordingError(
            f"the robot bends about one axis (robot.bending_axes = 1), but theta_y is {arrays[c][row]:g} rad",
            file=source,
            column=c,
            row=row,
        )


def check_robot_meta(robot: Mapping[str, Any] | None, n_modules: int, *, source: str | None = None) -> None:
    """Raise when the metadata's robot has another number of modules than the columns describe.

    Parameters
    ----------
    robot : mapping or None
        The ``robot`` metadata (normalised: its values are numbers).
    n_modules : int
        ``N`` of the recording (checked against its columns by :func:`check_n_modules`).
    source : str, optional
        File named in the error.
    """
    k = (robot or {}).get("n_modules")
    if k is not None and k != n_modules:
        raise RecordingError(
            f"metadata 'robot.n_modules' is {k!r} but the columns describe {n_modules} modules", file=source
        )


def check_history_window(frame: pd.DataFrame, h: int, *, source: str | None = None) -> None:
    """Raise when a trajectory has fewer than ``h`` frames (row: its first frame).

    Parameters
    ----------
    frame : pandas.DataFrame
        A validated recording's frame.
    h : int
        History window of a learned model [frames].
    source : str, optional
        File named in the error.

    Raises
    ------
    ConfigError
        When ``h`` is not a positive integer.
    RecordingError
        Naming the first too-short trajectory.
    """
    if not is_int(h) or h < 1:
        raise ConfigError(f"history window must be a positive integer, got {h!r}")
    starts = np.flatnonzero(trajectory_starts(pd.factorize(frame["trajectory"])[0]))
    lengths = np.diff(np.append(starts, len(frame)))
    short = np.flatnonzero(lengths < h)
    if short.size:
        s = int(short[0])
        tid = str(frame["trajectory"].iloc[int(starts[s])])
        raise RecordingError(
            f"trajectory '{tid}' has {int(lengths[s])} frames, fewer than the history window of {int(h)} frames",
            file=source,
            column="trajectory",
            row=int(starts[s]),
        )


def validate(
    frame: pd.DataFrame, n_modules: int | None = None, *, source: str | None = None, n_tendons: int | None = None
) -> None:
    """Check a normalised frame against the schema; raise on the first problem.

    Runs, in order: :func:`check_not_empty`, :func:`check_numbering`, :func:`check_n_modules`,
    :func:`check_required_columns`, :func:`check_numeric`, :func:`~tendon_id.data.rules.trajectory_codes`,
    :func:`check_contiguous_trajectories`, :func:`check_finite`,
    :func:`check_positive_tensions`, :func:`check_tension_magnitude`, :func:`check_angles_in_rad`,
    :func:`check_time_increases`.

    Parameters
    ----------
    frame : pandas.DataFrame
        The data, normalised by :func:`~tendon_id.data.normalise.normalise_frame`.
    n_modules : int, optional
        ``N`` from the metadata; None takes it from the columns.
    source : str, optional
        File named in the errors.
    n_tendons : int, optional
        Tendons per set from the metadata's robot; None takes it from the columns.

    Raises
    ------
    RecordingError
        Naming the file, the column and the 0-based frame row of the first offending value.
    """
    check_not_empty(frame, source=source)
    cols = list(frame.columns)
    n_t = tendon_count({"n_tendons": n_tendons} if n_tendons else None, cols)
    check_numbering(cols, n_t, source=source)
    n = check_n_modules(cols, n_modules, source=source)
    check_required_columns(cols, n, n_t, source=source)
    numeric = [c for c in required_columns(n, n_t) if c != "trajectory"]
    numeric += [c for c in truth_columns(n, n_t) if c in frame.columns]
    check_numeric(frame, numeric, source=source)

    ids, names = trajectory_codes(frame, source=source)
    check_contiguous_trajectories(ids, source=source, names=names)

    # Finite values first, so the sign and range checks below see numbers only.
    arrays = {c: float_column(frame, c) for c in numeric}
    check_finite(arrays, source=source)
    check_representable(arrays, source=source)
    tensions = {c: a for c, a in arrays.items() if c.startswith("tension_")}
    check_positive_tensions(tensions, source=source)
    check_tension_magnitude(tensions, source=source)
    check_angles_in_rad({c: arrays[c] for c in theta_columns(n)}, source=source)
    check_time_increases(arrays["t"], ids, source=source, names=names)
