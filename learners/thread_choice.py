"""Choosing one or two threads per streamed frame from the frame times themselves.

A helper thread halves the paper preset's frame on an idle 2-core machine, but where another
process keeps a core busy the two threads meet eleven times a frame across a shared core, and
one thread is faster (``tendon-id benchmark latency`` measures both, idle and loaded, in one
run).  A robot's computer is neither always idle nor always busy, so the streaming engine
times its frames and runs the count whose recent frames were faster, trying the other one now and
then to notice when the load changes.  One and two threads give the same bits, so the choice
changes only the time.
"""

from __future__ import annotations

from collections import deque
from statistics import median

#: One frame in this many runs on the count not in use, to keep its time current.
PROBE_EVERY = 32
#: Frame times kept per count; their median is compared (a median, so that one frame delayed by
#: the scheduler does not flip the choice).
KEEP = 9


class ThreadChooser:
    """Runs the faster of 1 and 2 threads by the median of their last frame times.

    Parameters
    ----------
    start : int
        The count of the first frame (1 or 2).
    probe_every : int
        Every ``probe_every``-th frame runs on the other count.
    keep : int
        Frame times kept per count.
    """

    def __init__(self, start: int = 2, probe_every: int = PROBE_EVERY, keep: int = KEEP):
        if start not in (1, 2) or probe_every < 2 or keep < 1:
            raise ValueError("start must be 1 or 2, probe_every >= 2 and keep >= 1")
        self.current, self.probe_every = start, int(probe_every)
        self.times: dict[int, deque] = {1: deque(maxlen=keep), 2: deque(maxlen=keep)}
        self.frames = 0

    def next(self) -> int:
        """The thread count of the next frame."""
        self.frames += 1
        other = 3 - self.current
        # The other count's first time is taken on the second frame, after the first has warmed up.
        if (not self.times[other] and self.frames >= 2) or self.frames % self.probe_every == 0:
            return other
        return self.current

    def record(self, threads: int, seconds: float) -> None:
        """The time [s] a frame on ``threads`` took; switches to the other count once it is faster."""
        self.times[threads].append(seconds)
        if self.times[1] and self.times[2]:
            self.current = 1 if median(self.times[1]) < median(self.times[2]) else 2
