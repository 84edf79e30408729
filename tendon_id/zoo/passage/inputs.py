"""What a passage model reads from single-passage recordings, as arrays over all frames."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from friction_models import play_operator
from tendon_id.data.frame import FrameRecording
from tendon_id.data.passage import PassageRecording
from tendon_id.errors import ConfigError
from tendon_id.family.inputs import FrameInputs, by_slices, frame_slices

#: Window of the backward difference that gives the input speed [s] (an encoder count per
#: frame is too coarse at 1 kHz; 20 ms averages it while lagging the motion by 10 ms).
SPEED_WINDOW_S = 0.02
#: Frames of one window of a streamed evaluation (:meth:`FrameInputs.window`): its temporaries are
#: a few MB whatever the log's length, and 2^16 frames amortise numpy's per-call cost.
WINDOW_FRAMES = 1 << 16


def as_passages(data: PassageRecording | Sequence[PassageRecording]) -> list[PassageRecording]:
    """A list of passage recordings from one or a sequence of them (same quantity)."""
    recs = [data] if isinstance(data, FrameRecording) else list(data)
    other = next((r for r in recs if not isinstance(r, PassageRecording)), None)
    if not recs or other is not None:
        got = "nothing" if not recs else f"{getattr(other, 'source', None) or 'a recording'} ({type(other).__name__})"
        raise ConfigError(
            f"a passage model reads single-passage recordings (read a bench's files through a mapping), got {got}"
        )
    if len({r.quantity for r in recs}) > 1:
        raise ConfigError("the recordings mix tension and torque passages")
    return recs


@dataclass(frozen=True, eq=False)
class PassageInputs(FrameInputs):
    """The arrays of one or more passage recordings, stacked in time: the bench passage's inputs.

    Attributes
    ----------
    input, output : ndarray, shape (T,)
        Input- and output-side signal [N or N m].
    position : ndarray, shape (T,) or None
        Input-side position [rad].
    position_out : ndarray, shape (T,) or None
        Output-side position [rad].
    wrap : ndarray, shape (T,) or None
        Wrap angle [rad]; None where it is inferred (then the capstan exponent is fitted).
    reset : ndarray of bool, shape (T,)
        Trajectory starts.
    dt : float
        Sample period [s].
    quantity : str
        ``torque`` or ``tension``.
    """

    frame_fields: ClassVar[tuple[str, ...]] = (
        "input",
        "output",
        "position",
        "position_out",
        "wrap",
        "reset",
    )

    input: NDArray
    output: NDArray
    position: NDArray | None
    position_out: NDArray | None
    wrap: NDArray | None
    reset: NDArray
    dt: float
    quantity: str
    cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @classmethod
    def from_recordings(cls, data) -> PassageInputs:
        recs = as_passages(data)
        dts = {round(r.dt, 12) for r in recs}
        if len(dts) > 1:
            raise ConfigError(f"the recordings have different sample periods: {sorted(dts)} s")

        def joined(parts):
            # One recording's arrays are its own (views); several are joined into one copy.
            return None if any(p is None for p in parts) else parts[0] if len(parts) == 1 else np.concatenate(parts)

        reset = joined([r.trajectory_starts for r in recs])
        # Read-only views of one recording's columns (the arrays are never written to).
        return cls(
            input=joined([r.column_view("input") for r in recs]),
            output=joined([r.column_view("output") for r in recs]),
            position=joined([r.column_view("position") for r in recs]),
            position_out=joined([r.column_view("position_out") for r in recs]),
            wrap=joined([r.wrap() for r in recs]),
            reset=reset,
            dt=recs[0].dt,
            quantity=recs[0].quantity,
        )

    def travel(self) -> NDArray:
        """What the motion is measured in: the input position [rad], else the input signal."""
        return self.position if self.position is not None else self.input

    def direction(self, band: float) -> NDArray:
        """Direction of motion of the input, +1 or -1, held through pauses, int8, shape (T,).

        A play operator of half-width ``band`` on the travel: the direction changes once the
        travel has gone ``band`` back from its last turning point, so an encoder count that
        flickers does not flip it.
        """

        x, last = self.travel(), None  # the follower's output before the slice

        def fill(a, b):
            nonlocal last
            follower = play_operator(x[a:b], band, self.reset[a:b], y0=last).log_out
            last = follower[-1]
            return np.where(x[a:b] - follower >= 0, 1, -1)

        return self.memo(f"direction:{band!r}", lambda: by_slices(self.n_frames, np.int8, fill))

    def slip_state(self, band: float) -> NDArray:
        """The slip state of the paper's Eq. (6), memoryless: +1, -1, or 0 (stick), int8, shape (T,).

        The sign of the travel's change over the last SPEED_WINDOW_S where it exceeds ``band``,
        else 0: a model without a holding state knows only whether the input moves now.
        """

        x = self.travel()

        def fill(a, b):
            moved = x[a:b] - x[self._back(a, b)]
            return np.where(np.abs(moved) > band, np.sign(moved), 0.0)

        # int8: a state per frame is kept for every evaluation of a fit (a byte, not eight, at 1 kHz).
        return self.memo(f"slip:{band!r}", lambda: by_slices(self.n_frames, np.int8, fill))

    def first_motion(self, band: float) -> NDArray:
        """Each frame's trajectory's first slip state other than stick (+1 where it never moves), int8, shape (T,).

        Where a log starts, the friction state is unknown; the first motion tells which edge
        the passage is on, as :meth:`direction` (which starts forward) cannot.
        """

        def compute():
            sigma, n = self.slip_state(band), self.n_frames
            starts = np.flatnonzero(self.reset)
            if not starts.size:
                return np.ones(n, np.int8)
            ends = np.r_[starts[1:], n]
            # The first moving frame at or after each start, found slice by slice (the moving
            # frames of a whole log would be an index per frame).
            found = np.full(starts.size, -1, dtype=np.int64)
            for s in frame_slices(n):
                a, b = s.start, s.stop
                moving = a + np.flatnonzero(sigma[a:b])
                todo = np.flatnonzero((found < 0) & (starts < b))
                at = np.searchsorted(moving, starts[todo])
                hit = at < moving.size
                found[todo[hit]] = moving[at[hit]]
            own = (found >= 0) & (found < ends)  # in its own trajectory, not a later one
            first_sigma = np.where(own, sigma[np.maximum(found, 0)], 1).astype(np.int8)
            # Frames before the first start (none where frame 0 is a reset) read the first trajectory's.
            return np.repeat(first_sigma, np.diff(np.r_[0, starts[1:], n]))

        return self.memo(f"first_motion:{band!r}", compute)

    def _back(self, a: int = 0, b: int | None = None) -> NDArray:
        """Index of the frame SPEED_WINDOW_S before frames ``a`` to ``b - 1`` (not before their trajectory's start)."""
        b = self.n_frames if b is None else b
        n = max(int(round(SPEED_WINDOW_S / self.dt)), 1)
        return np.maximum(np.arange(a, b) - n, self.first_frame[a:b])

    def speed(self, keep: bool = True) -> NDArray:
        """Input speed [rad/s] (or the input signal's rate), a backward difference over SPEED_WINDOW_S.

        ``keep=False`` computes it without keeping it, where it is read once (a data scale).
        """

        x = self.travel()

        def fill(a, b):
            back = self._back(a, b)
            span = np.maximum(np.arange(a, b) - back, 1) * self.dt
            return (x[a:b] - x[back]) / span

        def compute():
            return by_slices(self.n_frames, float, fill)

        return self.memo("speed", compute) if keep or "speed" in self.cache else compute()

    def speed_magnitude(self) -> NDArray:
        """``|speed()|`` [rad/s], an array of the caller's own (to partition in place), not kept."""
        speed = self.speed(keep=False)
        return np.abs(speed) if "speed" in self.cache else np.abs(speed, out=speed)
