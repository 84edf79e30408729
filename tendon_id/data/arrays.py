"""Conversion between named numpy arrays and the columns of a recording (:doc:`/guide/data`).

:func:`frame_from_arrays` lays arrays such as ``angles`` (T, N, 2) out as schema columns;
:func:`column_block` reads columns back as one float64 array of a given shape.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from tendon_id.data.schema import truth_columns
from tendon_id.errors import RecordingError

__all__ = ["column_block", "concat_frames", "frame_from_arrays"]


def column_block(frame: pd.DataFrame, columns: list[str], shape: tuple[int, ...]) -> np.ndarray:
    """``frame[columns]`` as a fresh C-contiguous float64 array of ``shape`` (missing as NaN).

    Never a view of the frame (``to_numpy`` of one block can be one): what does not own its
    memory is copied, so a caller may keep it without a second copy of its own.
    """
    a = np.ascontiguousarray(frame[columns].to_numpy(dtype=np.float64, na_value=np.nan))
    return (a if a.flags.owndata else a.copy()).reshape(shape)


def frame_from_arrays(
    *,
    trajectory: str | Sequence[str] | np.ndarray,
    t: np.ndarray,
    angles: np.ndarray,
    actuator: np.ndarray,
    terminal: np.ndarray,
    joint_truth: np.ndarray | None = None,
    meta: Mapping[str, Any] | None = None,
    extra: Mapping[str, np.ndarray] | None = None,
) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The columns and metadata of a recording built from arrays.

    Parameters are those of :meth:`tendon_id.data.Recording.from_arrays`.

    Returns
    -------
    frame : pandas.DataFrame
        ``trajectory``, ``t``, the angles, the actuator tensions, the intermediate truth (when
        given), the terminal tensions, then ``extra``; not yet normalised or validated.
    meta : dict
        A copy of ``meta`` with ``n_modules`` defaulting to ``N`` from ``angles``.

    Raises
    ------
    RecordingError
        For arrays of inconsistent shapes, a ``joint_truth`` whose last joint differs from
        ``terminal``, or an extra column that collides with a schema column.
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
    if actuator.ndim != 3 or actuator.shape[:2] != (T, n) or actuator.shape[2] < 2:
        raise RecordingError(f"actuator must have shape (T={T}, N={n}, tendons >= 2), got {actuator.shape}")
    m = actuator.shape[2]
    terminal = np.asarray(terminal, dtype=np.float64)
    if terminal.shape != (T, m):
        raise RecordingError(f"terminal must have shape {(T, m)}, got {terminal.shape}")
    if isinstance(trajectory, str):
        traj = np.full(T, trajectory, dtype=object)
    else:
        traj = np.asarray(trajectory).astype(str).astype(object)
        if traj.shape != (T,):
            raise RecordingError(f"trajectory must have shape {(T,)}, got {traj.shape}", column="trajectory")

    data: dict[str, np.ndarray] = {"trajectory": traj, "t": t}
    for k in range(n):
        data[f"theta_{k + 1}_x"] = angles[:, k, 0]
        data[f"theta_{k + 1}_y"] = angles[:, k, 1]
    for j in range(n):
        for i in range(m):
            data[f"tension_act_{j + 1}_{i + 1}"] = actuator[:, j, i]
    if joint_truth is not None:
        jt = np.asarray(joint_truth, dtype=np.float64)
        if jt.shape not in ((T, n, m), (T, n - 1, m)):
            raise RecordingError(f"joint_truth must have shape {(T, n, m)} or {(T, n - 1, m)}, got {jt.shape}")
        if jt.shape[1] == n and not np.array_equal(jt[:, n - 1], terminal, equal_nan=True):
            raise RecordingError("joint_truth[:, N-1] must equal terminal", column=f"tension_joint_{n}_1")
        for j in range(n - 1):
            for i in range(m):
                data[f"tension_joint_{j + 1}_{i + 1}"] = jt[:, j, i]
    for i in range(m):
        data[f"tension_joint_{n}_{i + 1}"] = terminal[:, i]
    for name, values in (extra or {}).items():
        name = str(name)
        if name in data:
            raise RecordingError("extra column collides with a schema column", column=name)
        values = np.asarray(values)
        if values.shape != (T,):
            raise RecordingError(f"extra column must have shape {(T,)}, got {values.shape}", column=name)
        data[name] = values
    meta = dict(meta or {})
    meta.setdefault("n_modules", n)
    given = (meta.get("robot") or {}).get("n_tendons")  # None: the columns say how many
    if given is not None and given != m:
        raise RecordingError(f"the arrays have {m} tendons per set but robot.n_tendons is {given}")
    return pd.DataFrame(data), meta


def concat_frames(recordings: Sequence[Any]) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The stacked frame and merged metadata of snake recordings already checked to stack.

    :meth:`Recording.concat <tendon_id.data.Recording.concat>` checks them (same robot size and
    sample rate, distinct trajectory ids) through its base class.

    Parameters
    ----------
    recordings : sequence of Recording

    Returns
    -------
    frame : pandas.DataFrame
        The rows of every input in order; intermediate truth columns only where every input
        has them, extra columns missing from some inputs filled with NaN.
    meta : dict
        The metadata of the first input; ``protocol``, ``recipe``, ``seed`` and ``robot`` are
        None where the inputs differ, ``effects`` is the union in order of first appearance.
    """
    recs = list(recordings)
    first = recs[0]
    n, m = first.n_modules, first.n_tendons
    truth = [c for c in truth_columns(n, m) if all(c in r.frame.columns for r in recs)]
    drop = set(truth_columns(n, m)) - set(truth)
    frames = [r.frame.drop(columns=[c for c in r.frame.columns if c in drop]) for r in recs]
    frame = pd.concat(frames, axis=0, ignore_index=True, sort=False)

    meta = first.meta
    others = [r.meta for r in recs[1:]]
    for key in ("protocol", "recipe", "seed", "robot"):
        if any(m[key] != meta[key] for m in others):
            meta[key] = None
    effects: list[str] = []
    for m in [meta] + others:
        effects += [e for e in m["effects"] if e not in effects]
    meta["effects"] = effects
    return frame, meta
