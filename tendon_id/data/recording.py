"""The :class:`Recording`: one frame-per-row DataFrame plus metadata (:doc:`/guide/data`).

The class holds the data and answers questions about it; the work is done by the modules
beside it: :mod:`~tendon_id.data.normalise` (input into canonical form),
:mod:`~tendon_id.data.validation` (the rules), :mod:`~tendon_id.data.io` (files),
:mod:`~tendon_id.data.arrays` (arrays <-> columns), :mod:`~tendon_id.data.select` (selection
by trajectory) and :mod:`~tendon_id.data.summary`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
import pandas as pd

from tendon_id.data import validation
from tendon_id.data.arrays import column_block, concat_frames, frame_from_arrays
from tendon_id.data.columns import infer_sample_rate
from tendon_id.data.frame import FrameRecording
from tendon_id.data.normalise import normalise_frame, normalise_meta
from tendon_id.data.schema import (
    META_ORDER,
    TENSION_RE,
    THETA_RE,
    act_columns,
    hidden_truth_columns,
    infer_n_modules,
    joint_columns,
    tendon_count,
    theta_columns,
    truth_columns,
)
from tendon_id.data.select import split_trajectories
from tendon_id.data.summary import format_summary, summarise
from tendon_id.errors import ConfigError, RecordingError
from tendon_id.family.registry import family_named

__all__ = ["Recording"]


class Recording(FrameRecording):
    """One recording of a snake robot: a frame-per-row DataFrame plus metadata (:doc:`/guide/data`).

    The snake chain's recording (:mod:`tendon_id.family`); what every recording shares is
    :class:`~tendon_id.data.frame.FrameRecording`'s.

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

    __slots__ = ("_n_tendons",)
    family = family_named("snake")

    def __init__(
        self,
        frame: pd.DataFrame,
        meta: Mapping[str, Any] | None = None,
        *,
        source: str | None = None,
        validate: bool = True,
    ):
        if not isinstance(frame, pd.DataFrame):
            raise TypeError(f"frame must be a pandas DataFrame, got {type(frame).__name__}")
        self._source = None if source is None else str(source)
        meta = normalise_meta(meta, self._source)
        frame = normalise_frame(frame, meta, self._source)
        self._frame = frame
        if meta["n_modules"] is None:
            meta["n_modules"] = infer_n_modules(list(frame.columns))[0]
        if meta["sample_rate_hz"] is None:
            meta["sample_rate_hz"] = infer_sample_rate(frame)
        self._meta = {k: meta[k] for k in META_ORDER}
        self._meta.update({k: v for k, v in meta.items() if k not in self._meta})
        self._n_tendons = tendon_count(self._meta["robot"], list(frame.columns))
        if validate:
            self.validate()

    # ---- properties -----------------------------------------------------------------------

    @property
    def n_modules(self) -> int:
        """int : Number of modules ``N``."""
        return self._meta["n_modules"]

    @property
    def n_tendons(self) -> int:
        """int : Tendons per set ``n``: the metadata's ``robot.n_tendons``, else the columns', else 3."""
        return self._n_tendons

    @property
    def protocol(self) -> str | None:
        """str or None : The motion protocol (:doc:`/guide/simulator`), if known."""
        return self._meta["protocol"]

    @property
    def angles(self) -> np.ndarray:
        """ndarray, shape (T, N, 2) : Joint angles [rad]; ``[:, k-1]`` = ``(theta_k_x, theta_k_y)``."""
        n = self.n_modules
        return column_block(self._frame, theta_columns(n), (self.n_frames, n, 2))

    @property
    def actuator(self) -> np.ndarray:
        """ndarray, shape (T, N, n) : Actuator-side tensions ``T[1, j, i]`` [N]; ``[:, j-1, i-1]``."""
        n, m = self.n_modules, self._n_tendons
        return column_block(self._frame, act_columns(n, m), (self.n_frames, n, m))

    @property
    def terminal(self) -> np.ndarray:
        """ndarray, shape (T, n) : Terminal joint-side tensions ``T[N, N, :]`` [N] (the label)."""
        m = self._n_tendons
        return column_block(self._frame, joint_columns(self.n_modules, m), (self.n_frames, m))

    @property
    def has_truth(self) -> bool:
        """bool : True when every intermediate truth column ``tension_joint_{j}_{i}``, j < N, exists."""
        cols = self._frame.columns
        return all(c in cols for c in truth_columns(self.n_modules, self._n_tendons))

    @property
    def joint_truth(self) -> np.ndarray | None:
        """ndarray, shape (T, N, n), or None : Joint-side tensions ``T[j, j, :]`` [N].

        Row ``j-1`` is joint ``j``; ``[:, N-1]`` is the terminal label. None unless all
        intermediate truth columns are present (simulated data only).
        """
        if not self.has_truth:
            return None
        n, m = self.n_modules, self._n_tendons
        cols = truth_columns(n, m) + joint_columns(n, m)
        return column_block(self._frame, cols, (self.n_frames, n, m))

    def __repr__(self) -> str:
        src = f", source={self._source!r}" if self._source else ""
        try:
            n_traj = len(self.trajectories)
        except KeyError:
            n_traj = "?"
        truth = self.has_truth if self.n_modules else False
        return (
            f"Recording(n_modules={self.n_modules}, n_frames={self.n_frames}, "
            f"trajectories={n_traj}, truth={truth}{src})"
        )

    # ---- constructors and IO ---------------------------------------------------------------

    @classmethod
    def from_arrays(
        cls,
        *,
        trajectory: str | Sequence[str] | np.ndarray,
        t: np.ndarray,
        angles: np.ndarray,
        actuator: np.ndarray,
        terminal: np.ndarray,
        joint_truth: np.ndarray | None = None,
        meta: Mapping[str, Any] | None = None,
        extra: Mapping[str, np.ndarray] | None = None,
    ) -> "Recording":
        """Build a recording from arrays.

        Parameters
        ----------
        trajectory : str or array-like of str, shape (T,)
            Trajectory id of each frame, or one id for all frames.
        t : array-like, shape (T,)
            Time within each trajectory [s].
        angles : array-like, shape (T, N, 2)
            Joint angles [rad].
        actuator : array-like, shape (T, N, n)
            Actuator-side tensions [N] of ``n`` tendons per set.
        terminal : array-like, shape (T, n)
            Terminal joint-side tensions [N].
        joint_truth : array-like, shape (T, N, n) or (T, N-1, n), optional
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
        frame, meta = frame_from_arrays(
            trajectory=trajectory,
            t=t,
            angles=angles,
            actuator=actuator,
            terminal=terminal,
            joint_truth=joint_truth,
            meta=meta,
            extra=extra,
        )
        return cls(frame, meta)

    @classmethod
    def read(cls, path: str | os.PathLike, *, validate: bool = True) -> "Recording":
        """Read a recording from ``.parquet`` (or ``.pq``) or ``.csv`` (plus sidecar ``.json``).

        For CSV, metadata is read from ``path.with_suffix(".json")`` when it exists; otherwise
        ``n_modules`` is inferred from the columns and defaults are used. ``validate=False``
        skips :meth:`validate`.

        Raises
        ------
        RecordingError
            Naming the file, for a missing or unreadable file, an unknown suffix, bad metadata
            or invalid data.
        """
        return super().read(path, validate=validate)

    # ---- selection -------------------------------------------------------------------------

    def _derive(self, frame: pd.DataFrame) -> "Recording":
        """A recording on a subset of this one's (already validated) data."""
        return Recording(frame, self._meta, source=self._source, validate=False)

    def split(self, fractions: Sequence[float] = (0.7, 0.3), *, seed: int = 0) -> tuple["Recording", ...]:
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
        parts = split_trajectories(self.trajectories, fractions, seed=seed, source=self._source)
        return tuple(self.select(ids) for ids in parts)

    @classmethod
    def _check_concat(cls, first: "Recording", other: "Recording") -> None:
        if other.n_modules != first.n_modules:
            raise RecordingError(
                f"cannot concatenate recordings with {first.n_modules} and {other.n_modules} modules", file=other.source
            )
        if other.n_tendons != first.n_tendons:
            raise RecordingError(
                f"cannot concatenate recordings with {first.n_tendons} and {other.n_tendons} tendons per set",
                file=other.source,
            )

    @classmethod
    def _concat_frames(cls, recs: list) -> tuple[pd.DataFrame, dict[str, Any]]:
        """Intermediate truth columns only where every input has them; extra columns missing from some
        inputs filled with NaN. Metadata from the first input; ``protocol``, ``recipe``, ``seed`` and
        ``robot`` become None where the inputs differ, and ``effects`` is the union in order of first
        appearance."""
        return concat_frames(recs)

    def fitting_view(self) -> "Recording":
        """A copy without the intermediate truth columns, for a model's ``fit``.

        Every ``tension_joint_{j}_{i}`` with ``j < N`` is removed, so code handed this view is
        structurally unable to read intermediate ground truth (``has_truth`` is False,
        ``joint_truth`` is None). The terminal label ``tension_joint_{N}_{i}`` is kept.

        Returns
        -------
        Recording
        """
        hidden = hidden_truth_columns(self._frame.columns, self.n_modules)
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
        return Recording(self._frame, meta, source=self._source, validate="n_modules" in updates)

    # ---- validation and summary ------------------------------------------------------------

    def validate(self) -> None:
        """Check the recording against the schema; raise on the first problem.

        Checks, in order: empty recording; duplicate, missing or inconsistently numbered
        columns and a ``n_modules`` that does not match them; non-numeric values; missing or
        empty trajectory ids; a trajectory split into non-contiguous blocks; NaN or inf values;
        non-positive tensions and tensions outside [1e-9, 1e6] N; angles that look like degrees
        (``|angle| > pi``); time that does not strictly increase within a trajectory; then a
        ``robot.n_modules`` in the metadata that differs from the columns. Checks are vectorised
        (per column); see :func:`tendon_id.data.validation.validate` and
        :func:`~tendon_id.data.validation.check_robot_meta`.

        Raises
        ------
        RecordingError
            Naming the file, the column and the 0-based frame row of the first offending value.
        """
        robot = self._meta["robot"] or {}
        validation.validate(self._frame, self._meta["n_modules"], source=self._source, n_tendons=robot.get("n_tendons"))
        validation.check_robot_meta(self._meta["robot"], self.n_modules, source=self._source)
        if robot.get("bending_axes") == 1:
            validation.check_planar(self._frame, self.n_modules, source=self._source)

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
        validation.check_history_window(self._frame, h, source=self._source)

    def describe(self) -> dict[str, Any]:
        """A JSON-serialisable description, for ``tendon-id info --json``.

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
        return summarise(self)

    def summary(self, name: str | None = None) -> str:
        """A few aligned lines for ``tendon-id info``; ``name`` is the file shown (default: the source)."""
        return format_summary(self.describe(), name or self._source or "-")

    # ---- a user's files (tendon_id.data.mapping) ----------------------------------------------
    mapping_keys: ClassVar[tuple[str, ...]] = ("meta",)

    @classmethod
    def mapping_options(cls, doc: dict, where: str) -> dict[str, Any]:
        """A mapping's ``[meta]`` table: the recording's metadata (``n_modules``, ``robot``).

        ``robot`` may name a robot file (``robot = "my-robot.toml"``, read beside the mapping, or a bundled
        robot's name), or be a table with ``file = ...`` and lengths and angles with units (:doc:`/guide/robot_file`);
        it is stored in SI with the keys it gave.
        """
        from pathlib import Path

        from tendon_id.data.mapping import table
        from tendon_id.geometry import si_description
        from tendon_id.robot_file import resolve_robot

        meta = dict(table(doc, "meta", set(), where))
        if meta.get("robot") is not None:
            try:
                meta["robot"] = si_description(resolve_robot(meta["robot"], base=Path(where).parent, where="robot"))
            except ConfigError as exc:
                raise ConfigError(f"{where}: [meta] {exc}") from None
        return {"meta": meta}

    @classmethod
    def mapping_counts(cls, options: dict[str, Any]) -> tuple[int | None, int]:
        """``N`` from ``[meta] n_modules`` or its robot (None if neither says), and the robot's tendons per set."""
        meta = options["meta"]
        robot = meta.get("robot") or {}
        n = meta.get("n_modules", robot.get("n_modules"))
        return (None if n is None else int(n)), int(robot.get("n_tendons", 3))

    @classmethod
    def mapped_signal(cls, column: str, options: dict[str, Any]) -> str | None:
        if column == "t":
            return "time"
        if THETA_RE.match(column):
            return "angle"
        return "tension" if TENSION_RE.match(column) else None

    @classmethod
    def from_mapped(cls, frame: pd.DataFrame, meta: dict[str, Any], options: dict[str, Any], source: str):
        return cls(frame, {**options["meta"], **meta}, source=source)
