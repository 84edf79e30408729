"""The kind of motion of a trajectory, from its joint angles alone: steps, scans or paths.

A learned correction can help on one kind of motion and hurt on another, so the prior guard
(:mod:`tendon_id.zoo.guard`) scores each kind on its own.  It cannot rely on a protocol label:
a real recording has none, and stacking recordings of several protocols drops it
(:meth:`~tendon_id.data.Recording.concat`).  So the kind is read from what every recording
has, the joint angles, by three rules whose thresholds are all in :class:`MotionKindRules`:

1. A joint **moves** at a frame when its bend changes faster than ``speed_deg_s``, measured
   over a window of ``window_s`` centred on the frame (a window, not one frame's difference,
   so that encoder quantisation and noise on a held joint do not read as motion).
2. **steps** (step-and-hold): in at least ``held_share`` of the frames no joint moves.  A
   trajectory that never moves counts as steps too: it is all hold.
3. Otherwise **scans** (one or a few joints sweeping while the others are held) when at most
   ``scan_share`` of the joints (at least one) are *active*, i.e. move in at least
   ``active_share`` of the frames; else **paths** (many joints moving together).

Reversals are not tested: both scans and paths have them, so they tell neither apart.  On the
simulator's protocols (:mod:`tendon_id.sim.protocols`) ``posterior-3`` and ``posterior-6``
read as steps, ``terminal-only`` and ``single-passage`` as scans and ``planned-paths`` as paths.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, fields
from typing import NamedTuple

import numpy as np

from tendon_id.checks import check_keys
from tendon_id.data import Recording
from tendon_id.errors import ConfigError
from tendon_id.zoo.inputs import as_recordings

#: The kinds, in the order reports list them.
KINDS = ("steps", "scans", "paths")

DEG = np.pi / 180.0


@dataclass(frozen=True)
class MotionKindRules:
    """Every threshold of :func:`motion_kind`, in one place.

    Parameters
    ----------
    window_s : float
        Width of the window a joint's speed is measured over [s], centred on each frame.
        1 s keeps a held joint's encoder steps (0.09 deg at 12 bits), and angle noise up to
        0.2 deg, under ``speed_deg_s``; half a second let 0.2 deg of noise read as motion
        everywhere.  A step's 0.7 s ramp then reads as about a second of motion.
    speed_deg_s : float
        Speed of a joint's bend above which it moves [deg/s]; the protocols move at up to
        8 deg/s (their quasi-static bound).
    held_share : float
        Share of the frames with no joint moving from which a trajectory is steps [-].  On
        the simulator's protocols (5 seeds, angle noise 0 to 0.2 deg) the posterior
        protocols hold 63–91 % of their frames, scans and paths 5–37 %.
    active_share : float
        Share of the frames in which a joint must move to be active [-].
    scan_share : float
        Largest share of the joints active in a scan [-] (at least one joint).
    """

    window_s: float = 1.0
    speed_deg_s: float = 1.0
    held_share: float = 0.5
    active_share: float = 0.1
    scan_share: float = 1.0 / 3.0

    def __post_init__(self) -> None:
        if not (self.window_s > 0 and self.speed_deg_s > 0):
            raise ConfigError("motion-kind rules need window_s > 0 and speed_deg_s > 0")
        for name in ("held_share", "active_share", "scan_share"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ConfigError(f"motion-kind rule {name} must be a share in [0, 1], got {getattr(self, name)}")

    def to_dict(self) -> dict[str, float]:
        """The thresholds as JSON, for a saved model to classify as it did when fitted."""
        return {k: float(v) for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, d: dict | None) -> MotionKindRules:
        """Rules from :meth:`to_dict` (missing keys take their defaults; unknown keys are an error)."""
        d = dict(d or {})
        check_keys(d, [f.name for f in fields(cls)], what="motion-kind rule")
        return cls(**d)


#: The rules every caller uses unless it passes others.
RULES = MotionKindRules()


def joint_motion(angles: np.ndarray, dt: float, rules: MotionKindRules = RULES) -> np.ndarray:
    """Whether each joint moves at each frame (rule 1 of the module).

    Parameters
    ----------
    angles : ndarray, shape (T, N, 2)
        One trajectory's joint angles [rad].
    dt : float
        Sample period [s].
    rules : MotionKindRules

    Returns
    -------
    ndarray of bool, shape (T, N)
        True where the bend's speed over the window exceeds ``rules.speed_deg_s``.  The
        window is one-sided at the ends; a one-frame trajectory never moves.
    """
    a = np.asarray(angles, dtype=float)
    if a.ndim != 3 or a.shape[2] != 2:
        raise ConfigError(f"angles must have shape (T, N, 2), got {a.shape}")
    if not dt > 0:
        raise ConfigError(f"the sample period must be positive, got {dt}")
    t = len(a)
    half = max(1, int(round(rules.window_s / (2.0 * dt))))
    idx = np.arange(t)
    hi, lo = np.minimum(idx + half, t - 1), np.maximum(idx - half, 0)
    span = (hi - lo) * dt  # [s]; 0 only for a one-frame trajectory
    # speed of the bend vector (theta_x, theta_y): a joint moving along any axis counts
    speed = np.linalg.norm(a[hi] - a[lo], axis=-1) / np.where(span > 0, span, np.inf)[:, None]
    return speed > rules.speed_deg_s * DEG


def motion_kind(angles: np.ndarray, dt: float, rules: MotionKindRules = RULES) -> str:
    """The kind of motion of one trajectory: ``"steps"``, ``"scans"`` or ``"paths"``.

    Parameters
    ----------
    angles : ndarray, shape (T, N, 2)
        One trajectory's joint angles [rad].
    dt : float
        Sample period [s].
    rules : MotionKindRules
        Thresholds (default :data:`RULES`); the rules are the module's.

    Returns
    -------
    str
        One of :data:`KINDS`.
    """
    moving = joint_motion(angles, dt, rules)
    if len(moving) == 0 or np.mean(~moving.any(axis=1)) >= rules.held_share:
        return "steps"
    active = int(np.sum(moving.mean(axis=0) >= rules.active_share))
    return "scans" if active <= max(1.0, rules.scan_share * moving.shape[1]) else "paths"


class TrajectoryKind(NamedTuple):
    """One trajectory's kind, where its frames lie in the stacked recordings, and its recording's protocol."""

    trajectory: str
    kind: str
    start: int  # first frame in the stacked recordings
    stop: int  # one past its last frame
    protocol: str | None  # the recording's meta["protocol"], beside the kind; never used to classify


def trajectory_kinds(data: Recording | Sequence[Recording], rules: MotionKindRules = RULES) -> list[TrajectoryKind]:
    """The kind of every trajectory of ``data``, in frame order.

    Parameters
    ----------
    data : Recording or sequence of Recording
    rules : MotionKindRules

    Returns
    -------
    list of TrajectoryKind
        ``start``/``stop`` index the frames of the recordings stacked in order (as models
        stack them for prediction).
    """
    out: list[TrajectoryKind] = []
    offset = 0
    for rec in as_recordings(data):
        angles, ids, protocol = rec.angles, rec.trajectory_ids, rec.protocol
        starts = np.flatnonzero(rec.trajectory_starts)  # trajectories are contiguous blocks
        for s, e in zip(starts, [*starts[1:], rec.n_frames]):
            kind = motion_kind(angles[s:e], rec.dt, rules)
            out.append(TrajectoryKind(str(ids[s]), kind, offset + int(s), offset + int(e), protocol))
        offset += rec.n_frames
    return out


def frame_kinds(data: Recording | Sequence[Recording], rules: MotionKindRules = RULES) -> np.ndarray:
    """The kind of each frame's trajectory, shape (T,), frames of the recordings stacked in order."""
    kinds = trajectory_kinds(data, rules)
    out = np.empty(kinds[-1].stop if kinds else 0, dtype=object)
    for k in kinds:
        out[k.start : k.stop] = k.kind
    return out.astype(str)


def split_by_kind(data: Recording | Sequence[Recording], rules: MotionKindRules = RULES) -> dict[str, list[Recording]]:
    """The trajectories of ``data`` grouped by kind.

    Returns
    -------
    dict
        ``{kind: [recording, ...]}`` for the kinds present, in :data:`KINDS` order; each
        recording is one input's selection of that kind's trajectories (kept per input, since
        two inputs may use the same trajectory ids).
    """
    out: dict[str, list[Recording]] = {}
    for rec in as_recordings(data):
        ids: dict[str, list[str]] = {}
        for k in trajectory_kinds(rec, rules):
            ids.setdefault(k.kind, []).append(k.trajectory)
        for kind, tids in ids.items():
            out.setdefault(kind, []).append(rec.select(tids))
    return {k: out[k] for k in KINDS if k in out}
