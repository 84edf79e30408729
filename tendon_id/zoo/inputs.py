"""What a transmission model reads from recordings: angles, actuator tensions, labels, geometry."""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from tendon_id.data import Recording
from tendon_id.data.frame import FrameRecording
from tendon_id.errors import ConfigError, DefaultedGeometryWarning
from tendon_id.family.inputs import FrameInputs
from tendon_id.geometry import RobotGeometry, backbone_wrap, si_description
from tendon_id.robot_file import resolve_robot
from tendon_id.sliding import guide_sliding_distance


def as_recordings(data: Recording | Sequence[Recording]) -> list[Recording]:
    """A list of recordings from one recording or a sequence of them."""
    recs = [data] if isinstance(data, FrameRecording) else list(data)
    other = next((r for r in recs if not isinstance(r, Recording)), None)
    if other is not None:
        raise ConfigError(
            f"{getattr(other, 'source', None) or 'a recording'} is a {type(other).__name__}: this model reads a "
            "snake robot's recordings (a passage model, passage-capstan, reads a bench's)"
        )
    if not recs:
        raise ConfigError("expected a Recording or a non-empty sequence of Recordings")
    return recs


def robot_of(recordings: Sequence[Recording], robot: dict | RobotGeometry | None = None) -> RobotGeometry:
    """The robot description: an explicit one, else the recordings' metadata, else the defaults.

    Whatever a description leaves out takes the paper robot's value, with a
    :class:`~tendon_id.errors.DefaultedGeometryWarning` naming it.

    Raises
    ------
    ConfigError
        If recordings disagree on the robot or the module count.
    """
    n, n_tendons = recordings[0].n_modules, recordings[0].n_tendons
    if any(r.n_modules != n for r in recordings):
        raise ConfigError("all recordings must have the same number of modules")
    if any(r.n_tendons != n_tendons for r in recordings):
        raise ConfigError("all recordings must have the same number of tendons per set")
    if isinstance(robot, RobotGeometry):
        geometry = robot
    else:
        if robot is not None:
            # A robot file's name or path, or a table (maybe with file = ...), with units (:doc:`/guide/robot_file`).
            described = si_description(resolve_robot(robot))
        else:
            metas = [r.meta.get("robot") for r in recordings]
            if any(m != metas[0] for m in metas):
                raise ConfigError(
                    "recordings come from different robots (their 'robot' metadata differ); pass robot= explicitly"
                )
            described = dict(metas[0] or {})
        # A description without a module or tendon count describes the robot the columns show.
        geometry = RobotGeometry.from_dict({"n_modules": n, "n_tendons": n_tendons, **described})
        source = recordings[0].source
        where = "the robot given" if robot is not None else f"the recordings{f' ({source})' if source else ''}"
        _warn_defaulted(geometry, described, where)
    if geometry.n_modules != n:
        raise ConfigError(f"the robot has {geometry.n_modules} modules but the data has {n}")
    if geometry.n_tendons != n_tendons:
        raise ConfigError(f"the robot has {geometry.n_tendons} tendons per set but the data has {n_tendons}")
    return geometry


def _warn_defaulted(geometry: RobotGeometry, described: dict, where: str) -> None:
    """Warn, naming each field and value, where a robot description left the robot to the defaults."""
    counts = ("n_modules", "n_tendons", "bending_axes", "azimuths")  # read from the data, or no length to default
    defaulted = {k: v for k, v in geometry.to_dict().items() if k not in counts and k not in described}
    if not defaulted:
        return
    values = ", ".join(f"{k}={v:.6g}" for k, v in defaulted.items())
    what = "describe no robot" if not described else "leave part of the robot undescribed"
    warnings.warn(
        f"{where} {what}; the paper robot's values stand in: {values} (SI units: m, rad). "
        "Give them in the recording's 'robot' metadata (a mapping's [meta] robot) or pass robot=",
        DefaultedGeometryWarning,
        stacklevel=3,
    )


@dataclass(frozen=True)
class TransmissionInputs(FrameInputs):
    """Everything an analytic transmission model reads, as arrays over all frames: the snake chain's inputs.

    Attributes
    ----------
    angles : ndarray, shape (T, N, 2)
        Joint angles [rad].
    actuator : ndarray, shape (T, N, n)
        Actuator-side tensions ``T[1, j, i]`` [N] of the ``n`` tendons of each set.
    terminal : ndarray, shape (T, n)
        Terminal joint-side labels ``T[N, N, i]`` [N].
    reset : ndarray of bool, shape (T,)
        First frame of each trajectory.
    clock : ndarray, shape (T,)
        Time since the start of the session [s]: each recording is a session (its
        trajectories back to back, as the simulator records them), so the clock restarts
        at every recording's first frame.
    dt : float
        Sample period [s].
    geometry : RobotGeometry
        The robot: its sizes and azimuths.  Its ``alpha_0`` and ``alpha_c`` are the simulator's
        truth, which no model reads (the capstan models fit both).
    slid : ndarray, shape (T, N-1)
        Cumulative sliding distance through each guide [m] (:attr:`slid`), computed when first
        read.  The constructor's ``_slid`` gives it where it is known from a larger whole; a
        :meth:`subset` or :meth:`concat` carries it that way.
    """

    frame_fields: ClassVar[tuple[str, ...]] = ("angles", "actuator", "terminal", "reset", "clock", "_slid")

    angles: NDArray[np.float64]
    actuator: NDArray[np.float64]
    terminal: NDArray[np.float64]
    reset: NDArray[np.bool_]
    clock: NDArray[np.float64]
    dt: float
    geometry: RobotGeometry = field(compare=False)
    # The sliding distance where these frames are part of a whole that knows it (a subset's), else None.
    _slid: NDArray[np.float64] | None = field(default=None, compare=False, repr=False)
    cache: dict = field(default_factory=dict, init=False, compare=False, repr=False)

    @property
    def n_modules(self) -> int:
        return self.angles.shape[1]

    @property
    def n_tendons(self) -> int:
        """Tendons per set ``n``."""
        return self.actuator.shape[2]

    @cached_property
    def bend_wrap(self) -> NDArray[np.float64]:
        """The joints' part of the backbone wrap, ``|theta_k| / 2 + |theta_{k+1}| / 2``, shape (T, N-1) [rad].

        Paper Eq. (3) without the routing wrap ``alpha_0``: a model adds its own, fitted
        (:meth:`wrap_at`), never the geometry's ``alpha_0``, which is the simulator's truth.
        """
        return backbone_wrap(self.angles, 0.0)

    def wrap_at(self, alpha_0: float) -> NDArray[np.float64]:
        """Backbone wrap per guide with routing wrap ``alpha_0`` [rad], paper Eq. (3), shape (T, N-1) [rad].

        Equal, bit for bit, to :func:`~tendon_id.geometry.backbone_wrap` with that ``alpha_0``.
        """
        return np.minimum(self.bend_wrap + float(alpha_0), np.pi)

    @property
    def slid(self) -> NDArray[np.float64]:
        """Cumulative mean sliding distance through each guide [m], shape (T, N-1), read-only.

        :func:`tendon_id.sliding.guide_sliding_distance` of the measured angles over all frames
        in order, :attr:`reset` as its reset (no motion into a trajectory's first frame): the
        distance only grows, across the trajectories of a recording, and restarts with each
        recording (a session, as :attr:`clock` does).  It starts at 0 on a session's first
        frame; what was slid before is unknown
        (the ``friction_drift`` block's ``prior_sliding_m``).  Computed when first read (about
        0.3 s for 50 000 frames of 12 modules, several times :meth:`from_recordings` itself),
        except where given: a part cut by :meth:`subset` keeps the whole's values, so held-out
        frames do not restart from 0.
        """
        if self._slid is not None:
            return self._slid
        return self.memo("slid", self._sliding_distance)

    def _sliding_distance(self) -> NDArray[np.float64]:
        slid = guide_sliding_distance(self.angles, self.reset, self.geometry, self.dt)
        # Each recording is a session, as for the clock (and the simulator): the distance restarts
        # where the clock does. A reset frame has no motion into it, so subtracting the distance at
        # the session's first frame restarts it at 0 there.
        starts = np.flatnonzero(np.r_[True, self.clock[1:] <= self.clock[:-1]])
        lengths = np.diff(np.r_[starts, len(self.clock)])
        slid = slid - np.repeat(slid[starts], lengths, axis=0)
        slid.flags.writeable = False  # shared by every part cut from these inputs
        return slid

    def _with_slid(self) -> TransmissionInputs:
        """These inputs with :attr:`slid` as a field, so that cutting or stacking keeps it."""
        return self if self._slid is not None else replace(self, _slid=self.slid)

    def subset(self, mask: NDArray) -> TransmissionInputs:
        """The frames of ``mask`` (whole trajectories), with the whole's sliding distance (:attr:`slid`).

        The distance runs over all of these inputs: recomputed on the part, a held-out
        trajectory would restart from 0.
        """
        return FrameInputs.subset(self._with_slid(), mask)

    def part(self, start: int, stop: int) -> TransmissionInputs:
        """Frames ``start`` to ``stop - 1`` as views (:meth:`FrameInputs.part`), with the whole's sliding distance."""
        return FrameInputs.part(self._with_slid(), start, stop)

    @classmethod
    def concat(cls, parts: Sequence[TransmissionInputs]) -> TransmissionInputs:
        """Inputs stacked in time, each part's sliding distance (:attr:`slid`) kept as the part has it."""
        return super().concat([p._with_slid() for p in parts])

    @cached_property
    def log_actuator(self) -> NDArray[np.float64]:
        """``ln T[0, j, i]`` [ln N], shape (T, N, n) (cached: the chain starts from it at every evaluation)."""
        return np.log(self.actuator)

    @classmethod
    def from_recordings(
        cls, data: Recording | Sequence[Recording], robot: dict | RobotGeometry | None = None
    ) -> TransmissionInputs:
        """Stack recordings (trajectories kept apart by ``reset``).

        Only angles, actuator-side tensions and the terminal labels are read, never
        intermediate joint-side truth.  The clock and the sliding distance (:attr:`slid`) restart
        with each recording, a session.
        """
        recs = as_recordings(data)
        geometry = robot_of(recs, robot)
        dts = {round(r.dt, 9) for r in recs}
        if len(dts) > 1:
            raise ConfigError(f"recordings have different sample rates: {sorted(1 / d for d in dts)} Hz")
        dt = recs[0].dt
        # A load cell's drift runs from its tare, at the start of a recording, not from an earlier file's.
        clocks = [np.arange(r.n_frames) * dt for r in recs]

        def joined(parts):
            # A recording's blocks are fresh arrays (column_block): one recording's are taken as they are.
            return parts[0] if len(parts) == 1 else np.concatenate(parts)

        return cls(
            angles=joined([r.angles for r in recs]),
            actuator=joined([r.actuator for r in recs]),
            terminal=joined([r.terminal for r in recs]),
            reset=joined([r.trajectory_starts for r in recs]),
            clock=joined(clocks),
            dt=dt,
            geometry=geometry,
        )
