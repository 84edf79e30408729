"""What every recording is: one frame-per-row DataFrame plus metadata, in SI units, cut into trajectories.

:class:`FrameRecording` holds what the recordings of every transmission family share
(:doc:`/guide/data`): the frame and its metadata, the file it came from, the trajectories and
the time, selection by trajectory, stacking, and the files (Parquet, or CSV with a JSON
sidecar, written atomically). A family's recording class (:class:`~tendon_id.data.Recording`
for the snake chain, :class:`~tendon_id.data.passage.PassageRecording` for the bench passage)
adds its own columns, checks and summary, and says how a user's files map onto its columns
(:mod:`tendon_id.data.mapping`).
"""

from __future__ import annotations

import abc
import copy
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pandas as pd

from tendon_id.data import rules
from tendon_id.data.columns import float_column
from tendon_id.data.io import read_frame, write_frame
from tendon_id.data.select import select_rows, unique_trajectories
from tendon_id.errors import RecordingError

__all__ = ["FrameRecording"]


class FrameRecording(abc.ABC):
    """Base of the recordings: the shared accessors (see the module docstring).

    A subclass sets ``family`` (``family_named("snake")``: the transmission family this
    recording feeds, :mod:`tendon_id.family`), builds ``_frame``, ``_meta`` and ``_source`` in its
    ``__init__`` (checking its own columns), and implements :meth:`describe`, :meth:`summary`
    and the mapping hooks.
    """

    __slots__ = ("_frame", "_meta", "_source")

    # ---- what every recording has ------------------------------------------------------------
    @property
    def frame(self) -> pd.DataFrame:
        """pandas.DataFrame : The data, one row per frame. Treat as read-only."""
        return self._frame

    @property
    def meta(self) -> dict[str, Any]:
        """dict : A copy of the metadata."""
        return copy.deepcopy(self._meta)

    @property
    def source(self) -> str | None:
        """str or None : The file this recording was read from, named in error messages."""
        return self._source

    @property
    def n_frames(self) -> int:
        """int : Number of frames (rows) ``T``."""
        return len(self._frame)

    def __len__(self) -> int:
        return len(self._frame)

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
        return np.array(float_column(self._frame, "t"), dtype=np.float64, copy=True)

    @property
    def trajectory_ids(self) -> np.ndarray:
        """ndarray of str, shape (T,) : Trajectory id of every frame."""
        return self._frame["trajectory"].to_numpy().astype(str)

    @property
    def trajectories(self) -> list[str]:
        """list of str : Trajectory ids in order of first appearance."""
        return unique_trajectories(self._frame)

    @property
    def trajectory_starts(self) -> np.ndarray:
        """ndarray of bool, shape (T,) : True on the first frame of each trajectory."""
        # From codes: a str per frame would be a Python object per frame.
        return rules.trajectory_starts(self.trajectory_codes)

    @property
    def trajectory_codes(self) -> np.ndarray:
        """ndarray of int, shape (T,) : Each frame's trajectory, numbered from 0 in order of first appearance."""
        return pd.factorize(self._frame["trajectory"])[0]

    def column_view(self, column: str) -> np.ndarray | None:
        """A numeric column as a read-only float64 array [SI], a view where it is float64, or None.

        For a model's inputs, which only read: an hour of 1 kHz data is not copied a second time.
        """
        if column not in self._frame.columns:
            return None
        v = float_column(self._frame, column).view()
        v.flags.writeable = False
        return v

    def signal(self, column: str) -> np.ndarray | None:
        """A numeric column as float64 [SI], or None where the recording has no such column."""
        return float_column(self._frame, column).copy() if column in self._frame.columns else None

    # ---- files ------------------------------------------------------------------------------
    @classmethod
    def read(cls, path: str | os.PathLike, **kwargs):
        """Read a recording of this class from ``.parquet`` (``.pq``) or ``.csv`` (plus sidecar ``.json``).

        Raises
        ------
        RecordingError
            Naming the file, for a missing or unreadable file, an unknown suffix, bad metadata
            or invalid data.
        """
        frame, meta = read_frame(Path(path))
        return cls(frame, meta, source=str(path), **kwargs)

    def write(self, path: str | os.PathLike) -> Path:
        """Write the recording atomically to ``.parquet`` (or ``.pq``) or ``.csv`` (+ ``.json``).

        Each file is written to a temporary file in the same folder, then renamed over the
        target, so readers never see a partial file. Parquet output is byte-identical for
        identical data and metadata (fixed writer options, no timestamps, no pandas metadata).
        For CSV the metadata goes to ``path.with_suffix(".json")``. Returns the path written.
        """
        return write_frame(self._frame, self._meta, Path(path))

    # ---- selections --------------------------------------------------------------------------
    def _derive(self, frame: pd.DataFrame):
        """A recording of this class on a subset of this one's (already checked) data."""
        return type(self)(frame, self._meta, source=self._source)

    def select(self, trajectories: Sequence[str]):
        """The recording of only the given trajectories (each must exist), in this recording's row order.

        Same metadata and source; rows in its errors refer to the selection.
        """
        return self._derive(select_rows(self._frame, trajectories, source=self._source))

    @classmethod
    def concat(cls, recordings: Sequence[FrameRecording]):
        """Stack recordings of this class; their trajectory ids must differ and their sample rates agree.

        What else must agree, and how the metadata merge, is the subclass's
        (:meth:`_check_concat`, :meth:`_concat_frames`).

        Raises
        ------
        RecordingError
            For an empty sequence, different sample rates, a trajectory id in two inputs, or
            what the subclass refuses.
        """
        recs = list(recordings)
        if not recs:
            raise RecordingError("cannot concatenate zero recordings")
        first = recs[0]
        seen: dict[str, str | None] = {}
        for r in recs:
            if not isinstance(r, cls):
                raise TypeError(f"expected {cls.__name__}, got {type(r).__name__}")
            cls._check_concat(first, r)
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
        frame, meta = cls._concat_frames(recs)
        return cls(frame, meta, source=first.source if len(recs) == 1 else None)

    @classmethod
    def _check_concat(cls, first: FrameRecording, other: FrameRecording) -> None:
        """Raise RecordingError where ``other`` cannot be stacked after ``first`` (default: nothing more to check)."""

    @classmethod
    def _concat_frames(cls, recs: list[FrameRecording]) -> tuple[pd.DataFrame, dict[str, Any]]:
        """The stacked frame and merged metadata (default: the rows in order, the first's metadata)."""
        return pd.concat([r.frame for r in recs], ignore_index=True, sort=False), recs[0].meta

    # ---- what each family says about itself ---------------------------------------------------
    #: The top-level keys of a mapping file that this kind reads (:meth:`mapping_options`).
    mapping_keys: ClassVar[tuple[str, ...]] = ()

    @abc.abstractmethod
    def describe(self) -> dict[str, Any]:
        """A JSON-serialisable description, for ``tendon-id info --json``."""

    @abc.abstractmethod
    def summary(self, name: str | None = None) -> str:
        """A few aligned lines for ``tendon-id info``; ``name`` is the file shown (default: the source)."""

    @classmethod
    def mapping_options(cls, doc: dict, where: str) -> dict[str, Any]:
        """This kind's own keys of a mapping file (:mod:`tendon_id.data.mapping`), checked."""
        return {}

    @classmethod
    def mapped_signal(cls, column: str, options: dict[str, Any]) -> str | None:
        """The kind of signal our ``column`` holds (``time``, ``angle``, ``tension``, ``torque``), or None if none.

        Default: only the time ``t``; a kind whose recording says no more cannot be read through a mapping.
        """
        return "time" if column == "t" else None

    @classmethod
    def mapping_counts(cls, options: dict[str, Any]) -> tuple[int | None, int]:
        """The module and tendon counts a mapping's patterns expand over (:mod:`tendon_id.data.patterns`).

        Default: no modules (a pattern over modules is an error) and one tendon.
        """
        return None, 1

    @classmethod
    def required_columns(cls, options: dict[str, Any]) -> tuple[str, ...]:
        """The columns a mapping must name."""
        return ("t",)

    @classmethod
    def from_mapped(cls, frame: pd.DataFrame, meta: dict[str, Any], options: dict[str, Any], source: str):
        """A recording of a user's file read through a mapping (columns in SI, metadata of the mapping)."""
        return cls(frame, meta, source=source)
