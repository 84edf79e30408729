"""The single-passage data kind: one tendon passage (or an antagonistic pair) on a bench (:doc:`/guide/data`).

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
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
import pandas as pd

from tendon_id.checks import check_choice
from tendon_id.data import rules
from tendon_id.data.columns import float_column, infer_sample_rate
from tendon_id.data.frame import FrameRecording
from tendon_id.data.validation import check_tension_magnitude
from tendon_id.errors import ConfigError, RecordingError
from tendon_id.family.registry import family_named

__all__ = ["PASSAGE_KIND", "QUANTITIES", "PASSAGE_COLUMNS", "OPTIONAL_COLUMNS", "PassageRecording"]

PASSAGE_KIND = "passage"
#: Quantity of the input and output signals, and its SI unit.
QUANTITIES = {"torque": "N*m", "tension": "N"}
#: Largest wrap angle a passage may have [rad]: a hundred turns. A cable bench's or an instrument's
#: passage wraps its pulleys by a few rad, and a snake's tendon by at most pi per joint; a larger
#: value is a unit error (degrees or encoder counts read as rad), and it drives the capstan
#: exponent's range (mu up to 3 / wrap_angle, :mod:`tendon_id.zoo.passage.fitting`) towards zero.
MAX_WRAP_ANGLE = 200.0 * np.pi
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
    if w is not None and not (isinstance(w, (int, float)) and not isinstance(w, bool) and 0 < w <= MAX_WRAP_ANGLE):
        raise RecordingError(
            f"metadata wrap_angle must be a number in (0, {MAX_WRAP_ANGLE:.0f}] rad (a hundred turns) or null, "
            f"got {w!r}",
            file=source,
        )
    out.setdefault("sample_rate_hz", None)
    return out


class PassageRecording(FrameRecording):
    """One single-passage recording (see the module docstring): the bench passage family's recording.

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

    __slots__ = ()
    family = family_named("passage")

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
        ids, names = rules.trajectory_codes(f, source=src)
        rules.check_contiguous_trajectories(ids, source=src, names=names)
        arrays = {c: float_column(f, c) for c in numeric}
        rules.check_finite(arrays, source=src)
        rules.check_representable(arrays, source=src)
        if self.quantity == "tension":
            tensions = {c: arrays[c] for c in ("input", "output")}
            rules.check_positive_tensions(tensions, source=src)
            check_tension_magnitude(tensions, source=src)  # the same plausible range as a snake's tendons
        if "wrap" in arrays:
            bad = np.flatnonzero((arrays["wrap"] < 0) | (arrays["wrap"] > MAX_WRAP_ANGLE))
            if bad.size:
                w = float(arrays["wrap"][bad[0]])
                why = "negative wrap angle" if w < 0 else f"wrap angle {w:g} rad beyond a hundred turns"
                raise RecordingError(why, file=src, column="wrap", row=int(bad[0]))
        rules.check_time_increases(arrays["t"], ids, source=src, names=names)

    # ---- what a model reads ------------------------------------------------------------
    @property
    def quantity(self) -> str:
        """str : ``"torque"`` [N m] (an antagonistic pair) or ``"tension"`` [N] (one tendon)."""
        return self._meta["quantity"]

    @property
    def unit(self) -> str:
        """str : SI unit of ``input`` and ``output``."""
        return QUANTITIES[self.quantity]

    @property
    def input(self) -> np.ndarray:
        """ndarray, shape (T,) : Input-side tension [N] or torque [N m]."""
        return float_column(self._frame, "input").copy()

    @property
    def output(self) -> np.ndarray:
        """ndarray, shape (T,) : Output-side tension [N] or torque [N m]."""
        return float_column(self._frame, "output").copy()

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
    def _check_concat(cls, first: PassageRecording, other: PassageRecording) -> None:
        if other.quantity != first.quantity:
            raise RecordingError(
                f"cannot concatenate a {first.quantity} passage and a {other.quantity} passage", file=other.source
            )

    def describe(self) -> dict[str, Any]:
        """JSON-able description for ``tendon-id info --json``: frames, trajectories, ranges in SI units."""
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

    def summary(self, name: str | None = None) -> str:
        """A few aligned lines for ``tendon-id info``; ``name`` is the file shown (default: the source)."""
        s = self.describe()
        wrap = s["wrap_angle"]
        what = "an antagonistic pair" if s["quantity"] == "torque" else "a single tendon"
        lines = [
            f"passage       {name or self._source or '-'}",
            f"quantity      {s['quantity']} ({what})",
            f"frames        {s['n_frames']}  ({s['duration_s']:.1f} s at {s['sample_rate_hz']:g} Hz)",
            f"trajectories  {s['n_trajectories']}",
            f"wrap angle    {'inferred (the capstan exponent is fitted)' if wrap is None else f'{wrap:.4g} rad'}",
        ]
        for key, r in s["ranges"].items():
            label, _, unit = key.rpartition("_")
            lines.append(f"{label:13s} {r['min']:.4g} .. {r['max']:.4g} {unit.replace('*', ' ')}")
        return "\n".join(lines)

    # ---- a user's files (tendon_id.data.mapping) ----------------------------------------------
    mapping_keys: ClassVar[tuple[str, ...]] = ("quantity", "geometry")

    @classmethod
    def mapping_options(cls, doc: dict, where: str) -> dict[str, Any]:
        """``quantity`` (default ``"tension"``) and ``[geometry] wrap_angle`` (``"infer"``, [rad] or ``"120 deg"``)."""
        from tendon_id.data.mapping import table
        from tendon_id.data.units import si_factor

        quantity = check_choice(f"{where}: quantity", doc.get("quantity", "tension"), QUANTITIES, what="quantity")
        wrap = table(doc, "geometry", {"wrap_angle"}, where).get("wrap_angle", "infer")
        if wrap == "infer":
            wrap = None
        elif isinstance(wrap, (int, float)) and not isinstance(wrap, bool):
            wrap = float(wrap)
        else:
            wrap = si_factor(str(wrap), "angle", where=f"{where}: geometry.wrap_angle")
        if wrap is not None and not 0 < wrap <= MAX_WRAP_ANGLE:
            raise ConfigError(
                f"{where}: geometry.wrap_angle must be in (0, {MAX_WRAP_ANGLE:.0f}] rad (a hundred turns) or 'infer', "
                f"got {wrap!r} rad"
            )
        return {"quantity": quantity, "wrap_angle": wrap}

    @classmethod
    def mapped_signal(cls, column: str, options: dict[str, Any]) -> str | None:
        if column == "t":
            return "time"
        if column in ("input", "output"):
            return options["quantity"]
        return "angle" if column in OPTIONAL_COLUMNS else None

    @classmethod
    def required_columns(cls, options: dict[str, Any]) -> tuple[str, ...]:
        return PASSAGE_COLUMNS[1:]

    @classmethod
    def from_mapped(cls, frame: pd.DataFrame, meta: dict[str, Any], options: dict[str, Any], source: str):
        meta = {**meta, "kind": PASSAGE_KIND, "quantity": options["quantity"], "wrap_angle": options["wrap_angle"]}
        return cls(frame, meta, source=source)


def _range(a: np.ndarray) -> dict[str, float]:
    return {"min": float(np.min(a)), "max": float(np.max(a))}
