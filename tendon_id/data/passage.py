"""The single-passage data kind: one tendon passage (or an antagonistic pair) on a bench (DESIGN §14).

A :class:`PassageRecording` is one DataFrame with one row per frame plus metadata, like a
:class:`~tendon_id.data.Recording`, in SI units:

==================  =================================================================
``trajectory``      trajectory id (str); one per file by default; splits are made by it
``t``               time within the trajectory [s], strictly increasing
``input``           input-side signal: tension [N] or, for an antagonistic pair, torque [N m]
``output``          output-side signal, same quantity and sign convention (in phase with input)
``position``        input-side position [rad] (optional: the slip direction is read from it)
``position_out``    output-side position [rad] (optional)
``wrap``            the passage's wrap angle [rad] (optional: else ``meta["wrap_angle"]``)
==================  =================================================================

Metadata: ``kind = "passage"``, ``quantity`` (``"torque"`` or ``"tension"``), ``wrap_angle``
(constant wrap [rad], or None where it is inferred), ``sample_rate_hz``, and anything else
(``source_files``, ``citation``). The same files as a recording: Parquet, or CSV with a
``.json`` sidecar.
"""

from __future__ import annotations

import copy
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from tendon_id.data import validation as rules
from tendon_id.data.io import read_frame, write_frame
from tendon_id.data.normalise import float_column, infer_sample_rate
from tendon_id.errors import RecordingError

__all__ = ["PASSAGE_KIND", "QUANTITIES", "PASSAGE_COLUMNS", "OPTIONAL_COLUMNS", "PassageRecording"]

PASSAGE_KIND = "passage"
#: Quantity of the input and output signals, and its SI unit.
QUANTITIES = {"torque": "N*m", "tension": "N"}
#: Columns every passage recording has.
PASSAGE_COLUMNS = ("trajectory", "t", "input", "output")
#: Columns it may have.
OPTIONAL_COLUMNS = ("position", "position_out", "wrap")


def _meta(meta: Mapping[str, Any] | None, source: str | None) -> dict[str, Any]:
    out = dict(copy.deepcopy(dict(meta or {})))
    kind = out.setdefault("kind", PASSAGE_KIND)
    if kind != PASSAGE_KIND:
        raise RecordingError(f"metadata kind is {kind!r}, not a single passage ({PASSAGE_KIND!r})", file=source)
    q = out.setdefault("quantity", "tension")
    if q not in QUANTITIES:
        raise RecordingError(f"metadata quantity {q!r} is not one of {', '.join(QUANTITIES)}", file=source)
    w = out.setdefault("wrap_angle", None)
    if w is not None and not (isinstance(w, (int, float)) and np.isfinite(w) and w > 0):
        raise RecordingError(f"metadata wrap_angle must be a positive number [rad] or null, got {w!r}", file=source)
    out.setdefault("sample_rate_hz", None)
    return out


class PassageRecording:
    """One single-passage recording (see the module docstring).

    Parameters
    ----------
    frame : pandas.DataFrame
        The columns of :data:`PASSAGE_COLUMNS`, and any of :data:`OPTIONAL_COLUMNS`, in SI units.
        Extra columns are kept and ignored.
    meta : mapping, optional
        ``quantity`` (default ``"tension"``), ``wrap_angle`` [rad] or None, ``sample_rate_hz``.
    source : str, optional
        File the data came from; named in error messages.

    Raises
    ------
    RecordingError
        Naming the file, the column and the 0-based row of the first offending value.
    """

    __slots__ = ("_frame", "_meta", "_source")

    def __init__(self, frame: pd.DataFrame, meta: Mapping[str, Any] | None = None, *, source: str | None = None):
        if not isinstance(frame, pd.DataFrame):
            raise TypeError(f"frame must be a pandas DataFrame, got {type(frame).__name__}")
        self._source = None if source is None else str(source)
        self._meta = _meta(meta, self._source)
        frame = frame.reset_index(drop=True)
        missing = [c for c in PASSAGE_COLUMNS if c not in frame.columns]
        if missing:
            raise RecordingError(f"missing column(s) {', '.join(missing)} of a single passage", file=self._source)
        frame = frame.assign(trajectory=frame["trajectory"].astype(str))
        self._frame = frame
        self._validate()
        if self._meta["sample_rate_hz"] is None:
            self._meta["sample_rate_hz"] = infer_sample_rate(frame)

    def _validate(self) -> None:
        f, src = self._frame, self._source
        rules.check_not_empty(f, source=src)
        numeric = [c for c in PASSAGE_COLUMNS[1:] + OPTIONAL_COLUMNS if c in f.columns]
        rules.check_numeric(f, numeric, source=src)
        ids = rules.check_trajectory_ids(f, source=src)
        rules.check_contiguous_trajectories(ids, source=src)
        arrays = {c: float_column(f, c) for c in numeric}
        rules.check_finite(arrays, source=src)
        if self.quantity == "tension":
            rules.check_positive_tensions({c: arrays[c] for c in ("input", "output")}, source=src)
        if "wrap" in arrays:
            bad = np.flatnonzero(arrays["wrap"] < 0)
            if bad.size:
                raise RecordingError("negative wrap angle", file=src, column="wrap", row=int(bad[0]))
        rules.check_time_increases(arrays["t"], ids, source=src)

    # ---- what a model reads ------------------------------------------------------------
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
        """str or None : The file this recording was read from."""
        return self._source

    @property
    def quantity(self) -> str:
        """str : ``"torque"`` [N m] (an antagonistic pair) or ``"tension"`` [N] (one tendon)."""
        return self._meta["quantity"]

    @property
    def unit(self) -> str:
        """str : SI unit of ``input`` and ``output``."""
        return QUANTITIES[self.quantity]

    @property
    def n_frames(self) -> int:
        return len(self._frame)

    def __len__(self) -> int:
        return self.n_frames

    @property
    def sample_rate_hz(self) -> float:
        return float(self._meta["sample_rate_hz"])

    @property
    def dt(self) -> float:
        """float : Sample period [s]."""
        return 1.0 / self.sample_rate_hz

    @property
    def time(self) -> np.ndarray:
        return float_column(self._frame, "t").copy()

    @property
    def trajectory_ids(self) -> np.ndarray:
        return self._frame["trajectory"].to_numpy().astype(str)

    @property
    def trajectories(self) -> list[str]:
        return list(dict.fromkeys(self.trajectory_ids))

    @property
    def trajectory_starts(self) -> np.ndarray:
        """ndarray of bool, shape (T,) : True on the first frame of each trajectory."""
        return rules.trajectory_starts(self.trajectory_ids)

    @property
    def input(self) -> np.ndarray:
        """ndarray, shape (T,) : Input-side tension [N] or torque [N m]."""
        return float_column(self._frame, "input").copy()

    @property
    def output(self) -> np.ndarray:
        """ndarray, shape (T,) : Output-side tension [N] or torque [N m]."""
        return float_column(self._frame, "output").copy()

    def signal(self, column: str) -> np.ndarray | None:
        """An optional column (``position``, ``position_out``, ``wrap``) as float64, or None."""
        return float_column(self._frame, column).copy() if column in self._frame.columns else None

    def wrap(self) -> np.ndarray | None:
        """ndarray, shape (T,) : The wrap angle of each frame [rad], or None where it is inferred."""
        w = self.signal("wrap")
        if w is None and self._meta["wrap_angle"] is not None:
            w = np.full(self.n_frames, float(self._meta["wrap_angle"]))
        return w

    def __repr__(self) -> str:
        src = f", source={self._source!r}" if self._source else ""
        return f"PassageRecording({self.n_frames} frames, {len(self.trajectories)} trajectories, {self.quantity}{src})"

    # ---- files and selections ----------------------------------------------------------
    @classmethod
    def read(cls, path: str | os.PathLike) -> PassageRecording:
        """Read a passage recording in our own format (Parquet, or CSV with its sidecar)."""
        frame, meta = read_frame(Path(path))
        return cls(frame, meta, source=str(path))

    def write(self, path: str | os.PathLike) -> Path:
        """Write atomically to ``.parquet`` or ``.csv`` (+ ``.json`` sidecar). Returns the path."""
        return write_frame(self._frame, self._meta, Path(path))

    def select(self, trajectories: Sequence[str]) -> PassageRecording:
        """The frames of ``trajectories`` (in this recording's order)."""
        keep = np.isin(self.trajectory_ids, list(trajectories))
        if not keep.any():
            raise RecordingError(f"none of the trajectories {list(trajectories)} is in the data", file=self._source)
        return PassageRecording(self._frame[keep], self._meta, source=self._source)

    @staticmethod
    def concat(recordings: Sequence[PassageRecording]) -> PassageRecording:
        """One recording of several, which must share the quantity; trajectory ids must differ."""
        recs = list(recordings)
        if not recs:
            raise RecordingError("cannot concatenate zero recordings")
        first = recs[0]
        seen: set[str] = set()
        for r in recs:
            if r.quantity != first.quantity:
                raise RecordingError(
                    f"cannot concatenate a {first.quantity} passage and a {r.quantity} passage", file=r.source
                )
            dup = seen & set(r.trajectories)
            if dup:
                raise RecordingError(f"trajectory id {sorted(dup)[0]!r} appears twice; rename one", file=r.source)
            seen |= set(r.trajectories)
        frame = pd.concat([r.frame for r in recs], ignore_index=True, sort=False)
        meta = first.meta
        meta["sample_rate_hz"] = None if len({r.sample_rate_hz for r in recs}) > 1 else first.sample_rate_hz
        return PassageRecording(frame, meta, source=first.source if len(recs) == 1 else None)

    def summary(self) -> dict[str, Any]:
        """JSON-able summary for ``tendon-id info``: frames, trajectories, ranges in SI units."""
        starts = np.flatnonzero(self.trajectory_starts)
        lengths = np.diff(np.append(starts, self.n_frames))
        ranges = {
            f"{c}_{'rad' if c.startswith(('position', 'wrap')) else self.unit}": _range(self.signal(c))
            for c in ("input", "output") + OPTIONAL_COLUMNS
            if c in self._frame.columns
        }
        return {
            "kind": PASSAGE_KIND,
            "quantity": self.quantity,
            "n_frames": self.n_frames,
            "n_trajectories": int(len(starts)),
            "trajectories": {str(self.trajectory_ids[s]): int(n) for s, n in zip(starts, lengths)},
            "duration_s": float(np.sum(lengths) * self.dt),
            "sample_rate_hz": self.sample_rate_hz,
            "wrap_angle": self._meta["wrap_angle"],
            "ranges": ranges,
        }


def _range(a: np.ndarray) -> dict[str, float]:
    return {"min": float(np.min(a)), "max": float(np.max(a))}
