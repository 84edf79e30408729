"""Selecting, splitting and stacking recordings by trajectory, never by frame.

These functions work on DataFrames and trajectory ids, whatever the recording's family; the
recording classes (:class:`~tendon_id.data.frame.FrameRecording`) wrap their results into new
recordings.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from tendon_id.errors import ConfigError, RecordingError

__all__ = ["unique_trajectories", "select_rows", "split_trajectories"]


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
