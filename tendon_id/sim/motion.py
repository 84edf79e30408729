"""Smooth, speed-limited joint motions from which the protocols are built."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def min_jerk_at(tau: NDArray) -> NDArray[np.float64]:
    """Minimum-jerk profile ``s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5``, held at 0 before and 1 after the move.

    Flash & Hogan, "The coordination of arm movements", J. Neurosci. 5(7),
    1985.  Its peak speed is ``1.875`` times the mean speed.
    """
    tau = np.clip(np.asarray(tau, dtype=float), 0.0, 1.0)
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)


def min_jerk(n: int) -> NDArray[np.float64]:
    """:func:`min_jerk_at` on ``n`` samples in (0, 1]."""
    return min_jerk_at(np.arange(1, n + 1) / n)


def min_jerk_duration(delta: float, v_max: float) -> float:
    """Duration [s] of a minimum-jerk move of size ``delta`` whose peak speed is ``v_max`` (same units per s)."""
    return 1.875 * abs(delta) / v_max


def move_frames(delta: float, v_max: float, dt: float, min_s: float = 0.5) -> int:
    """Frames for a minimum-jerk move of size ``delta`` [rad] whose peak speed stays below ``v_max`` [rad/s]."""
    duration = max(min_s, min_jerk_duration(delta, v_max))
    return max(1, int(np.ceil(duration / dt)))


class PathBuilder:
    """Appends holds and speed-limited minimum-jerk moves of all joints at once.

    Parameters
    ----------
    start : ndarray, shape (N, 2)
        Initial joint angles [rad].
    v_max : float
        Peak joint speed of any move [rad/s].
    dt : float
        Sample period [s].
    """

    def __init__(self, start: NDArray, v_max: float, dt: float):
        self._pieces = [np.asarray(start, dtype=float)[None]]
        self._last = np.asarray(start, dtype=float)
        self.v_max = v_max
        self.dt = dt

    @property
    def frames(self) -> int:
        """Frames built so far."""
        return sum(p.shape[0] for p in self._pieces)

    @property
    def last(self) -> NDArray:
        """A copy of the current pose, shape (N, 2) [rad]."""
        return self._last.copy()

    def hold(self, seconds: float) -> None:
        """Stay at the current pose for ``seconds`` [s]."""
        n = max(1, int(round(seconds / self.dt)))
        self._pieces.append(np.repeat(self._last[None], n, axis=0))

    def move_to(self, target: NDArray) -> None:
        """Minimum-jerk move of all joints to ``target`` (N, 2) [rad], as slow as the speed limit needs."""
        target = np.asarray(target, dtype=float)
        delta = target - self._last
        n = move_frames(float(np.abs(delta).max()), self.v_max, self.dt)
        s = min_jerk(n)
        self._pieces.append(self._last[None] + s[:, None, None] * delta[None])
        self._last = target

    def build(self, n_frames: int) -> NDArray:
        """The path cut (or held) to exactly ``n_frames`` frames, shape (n_frames, N, 2)."""
        path = np.concatenate(self._pieces, axis=0)
        if path.shape[0] < n_frames:
            path = np.concatenate([path, np.repeat(path[-1:], n_frames - path.shape[0], axis=0)])
        return path[:n_frames]


def smooth_noise(rng: np.random.Generator, n: int, shape: tuple, period_s: tuple[float, float], dt: float) -> NDArray:
    """Zero-mean slow variation of unit RMS: a sum of 3 random sinusoids per channel.

    Returns
    -------
    ndarray, shape (n,) + shape
    """
    t = np.arange(n)[:, None] * dt
    out = np.zeros((n,) + tuple(shape))
    flat = out.reshape(n, -1)
    for _ in range(3):
        periods = rng.uniform(*period_s, size=flat.shape[1])
        phases = rng.uniform(0, 2 * np.pi, size=flat.shape[1])
        flat += np.sin(2 * np.pi * t / periods + phases)
    return out * np.sqrt(2.0 / 3.0)
