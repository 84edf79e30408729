"""Selecting, splitting and stacking recordings by trajectory, never by frame.

These functions work on DataFrames, trajectory ids and (for :func:`concat_frames`) on
recordings through their public attributes; :class:`~tendon_id.data.Recording` wraps their
results into new recordings.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from tendon_id.data.schema import truth_columns
from tendon_id.errors import ConfigError, RecordingError

__all__ = ["unique_trajectories", "select_rows", "split_trajectories", "concat_frames"]


def unique_trajectories(frame: pd.DataFrame) -> list[str]:
    """Trajectory ids of ``frame`` as str, in order of first appearance."""
    return [str(x) for x in pd.unique(frame["trajectory"].to_numpy())]


def select_rows(frame: pd.DataFrame, trajectories: str | Sequence[str], *, source: str | None = None) -> pd.DataFrame:
    """The rows of the given trajectories, in ``frame``'s row order, with a fresh index.

    Parameters
    ----------
    frame : pandas.DataFrame
        A recording's frame.
    trajectories : str or sequence of str
        Trajectory ids; each must exist.
    source : str, optional
        File named in errors.

    Raises
    ------
    RecordingError
        For no ids or an id not in ``frame``.
    """
    if isinstance(trajectories, str):
        trajectories = [trajectories]
    wanted = [str(x) for x in trajectories]
    if not wanted:
        raise RecordingError(
            "cannot select zero trajectories (the recording would be empty)", file=source, column="trajectory"
        )
    have = set(unique_trajectories(frame))
    for w in wanted:
        if w not in have:
            raise RecordingError(f"no trajectory '{w}' in this recording", file=source, column="trajectory")
    mask = frame["trajectory"].isin(wanted).to_numpy()
    return frame.loc[mask].reset_index(drop=True)


def split_trajectories(
    ids: Sequence[str], fractions: Sequence[float], *, seed: int, source: str | None = None
) -> list[list[str]]:
    """Deal trajectory ids out into parts in proportion to ``fractions``.

    The ids are shuffled with ``numpy.random.default_rng(seed)``; part sizes follow the largest
    remainder, with at least one id per part.

    Parameters
    ----------
    ids : sequence of str
        Trajectory ids, in recording order.
    fractions : sequence of float
        Positive fractions of the ids for each part, summing to 1.
    seed : int
        Seed of the shuffle.
    source : str, optional
        File named in errors.

    Returns
    -------
    list of list of str
        One list per fraction, each in the order of ``ids``.

    Raises
    ------
    ConfigError
        For fractions that are not positive or do not sum to 1.
    RecordingError
        When there are fewer ids than parts.
    """
    f = np.asarray(list(fractions), dtype=np.float64)
    if f.ndim != 1 or f.size < 1 or not np.all(np.isfinite(f)) or np.any(f <= 0) or abs(f.sum() - 1.0) > 1e-6:
        raise ConfigError(f"split fractions must be positive and sum to 1, got {list(fractions)}")
    n, parts = len(ids), f.size
    if n < parts:
        raise RecordingError(
            f"cannot split {n} trajectories into {parts} non-empty parts; "
            "splits are made by trajectory, never by frame",
            file=source,
            column="trajectory",
        )
    raw = f * n
    counts = np.maximum(1, np.floor(raw)).astype(int)
    while counts.sum() < n:
        counts[int(np.argmax(raw - counts))] += 1
    while counts.sum() > n:
        over = np.where(counts > 1, counts - raw, -np.inf)
        counts[int(np.argmax(over))] -= 1
    order = np.random.default_rng(seed).permutation(n)
    bounds = np.concatenate([[0], np.cumsum(counts)])
    return [[ids[i] for i in sorted(order[bounds[p] : bounds[p + 1]])] for p in range(parts)]


def concat_frames(recordings: Sequence[Any], kind: type) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The stacked frame and merged metadata of recordings of the same robot size.

    Parameters
    ----------
    recordings : sequence of Recording
        Same ``n_modules`` and ``sample_rate_hz``; trajectory ids must not collide.
    kind : type
        The recording class every input must be an instance of (passed in by
        :meth:`Recording.concat <tendon_id.data.Recording.concat>`, which this module cannot
        import without a cycle).

    Returns
    -------
    frame : pandas.DataFrame
        The rows of every input in order; intermediate truth columns only where every input
        has them, extra columns missing from some inputs filled with NaN.
    meta : dict
        The metadata of the first input; ``protocol``, ``recipe``, ``seed`` and ``robot`` are
        None where the inputs differ, ``effects`` is the union in order of first appearance.

    Raises
    ------
    TypeError
        For an input that is not a ``kind``.
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
        if not isinstance(r, kind):
            raise TypeError(f"expected {kind.__name__}, got {type(r).__name__}")
        if r.n_modules != n:
            raise RecordingError(f"cannot concatenate recordings with {n} and {r.n_modules} modules", file=r.source)
        if not math.isclose(r.sample_rate_hz, first.sample_rate_hz, rel_tol=1e-9):
            raise RecordingError(
                f"cannot concatenate recordings sampled at {first.sample_rate_hz} Hz and {r.sample_rate_hz} Hz",
                file=r.source,
            )
        for tid in r.trajectories:
            if tid in seen:
                where = seen[tid] or "another recording"
                raise RecordingError(
                    f"trajectory id '{tid}' appears in {where} too; rename one", file=r.source, column="trajectory"
                )
            seen[tid] = r.source
    truth = [c for c in truth_columns(n) if all(c in r.frame.columns for r in recs)]
    drop = set(truth_columns(n)) - set(truth)
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
