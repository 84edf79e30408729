"""The state of a play operator, as numbers a learned correction can read.

A guide of the nonsmooth capstan (:mod:`friction_models.play_operator`) is a play operator
whose output ``y`` sits in the band ``[lo, hi] = [x - phi, x + phi]`` of its input ``x``
(all in ``ln T``).  What it will do next, and how far its present output can be trusted,
is told by four numbers per frame (the memory of the ``pg-chtc-ns`` cascade):

``sigma``
    +1 on the forward-slip edge, -1 on the reverse-slip edge, 0 stuck inside
    (:func:`friction_models.play_operator.slip_state`).
``position``
    Where the output sits in the band, ``(y - lo) / (hi - lo)`` in [0, 1]; 0 where the
    band has no width (no contact: forward slip).
``since_slip``
    ``ln(1 + t / 1 s)`` of the time ``t`` [s] since the output last moved, that is since the
    tendon last slid through the guide (the play operator's output moves only when an edge
    pushes it), or since the trajectory began if it has not slid yet.
``sweep``
    How much of the band the input has swept since the trajectory began,
    ``(max x - min x) / (hi - lo)``, clipped to [0, 1].  A log starts in an unknown stick
    state, which the model replaces by forward slip; once the input has crossed a whole
    band, every state in it has been driven to an edge, so the start guess is forgotten
    and the output is exact (for the band's present width).

Comparisons use a tolerance of :data:`TOL` (in ``ln T``), so that two evaluations of the
same frame that differ in the last bits (batch and streaming inference) read the same state.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

#: Numbers of state per guide and tendon: sigma, position, since_slip, sweep.
N_STATE = 4
#: Tolerance of the state's comparisons [ln N]: far below any physical change of tension.
TOL = 1e-9
#: Time scale of ``since_slip`` [s].
SINCE_SLIP_SCALE = 1.0


def _sigma_position(y: NDArray, lo: NDArray, hi: NDArray) -> tuple[NDArray, NDArray]:
    width = hi - lo
    has_band = width > TOL
    position = np.where(has_band, (y - lo) / np.where(has_band, width, 1.0), 0.0).clip(0.0, 1.0)
    sigma = np.where(y - lo <= TOL, 1.0, np.where(hi - y <= TOL, -1.0, 0.0))
    return sigma, position


def _sweep(x_max: NDArray, x_min: NDArray, lo: NDArray, hi: NDArray) -> NDArray:
    width = hi - lo
    return np.where(width > TOL, (x_max - x_min) / np.where(width > TOL, width, 1.0), 1.0).clip(0.0, 1.0)


def _segment_cummax(a: NDArray, segment: NDArray) -> NDArray:
    """Running maximum along axis 0 that restarts at every segment (``segment`` non-decreasing ints).

    Each segment is lifted above all earlier ones by a constant, so one cumulative maximum
    over the whole array cannot carry a value across a segment start.
    """
    span = float(np.nanmax(a) - np.nanmin(a)) + 1.0 if a.size else 1.0
    lift = (segment * span).reshape((-1,) + (1,) * (a.ndim - 1))
    return np.maximum.accumulate(a + lift, axis=0) - lift


def play_state(y: NDArray, lo: NDArray, hi: NDArray, reset: NDArray, dt: float) -> NDArray:
    """The state of a play operator over whole trajectories (see the module docstring).

    Parameters
    ----------
    y : ndarray, shape (T, ...)
        The play operator's output [ln N], as :func:`~friction_models.play_operator.play_output` gives it.
    lo, hi : ndarray, shape (T, ...)
        Its edges [ln N], ``lo <= hi``.
    reset : ndarray of bool, shape (T,)
        First frame of each trajectory (``reset[0]`` must be True).
    dt : float
        Sample period [s].

    Returns
    -------
    ndarray, shape (T, ..., 4)
        ``[sigma, position, since_slip, sweep]`` per frame.
    """
    reset = np.asarray(reset, dtype=bool)
    t = y.shape[0]
    sigma, position = _sigma_position(y, lo, hi)
    moved = np.zeros(y.shape, dtype=bool)
    moved[1:] = np.abs(y[1:] - y[:-1]) > TOL
    idx = np.arange(t).reshape((-1,) + (1,) * (y.ndim - 1))
    r = reset.reshape(idx.shape)
    last = np.maximum.accumulate(np.where(moved | r, idx, 0), axis=0)
    since = np.log1p((idx - last) * dt / SINCE_SLIP_SCALE)
    segment = np.cumsum(reset) - 1
    x = 0.5 * (lo + hi)
    sweep = _sweep(_segment_cummax(x, segment), -_segment_cummax(-x, segment), lo, hi)
    return np.stack([sigma, position, np.broadcast_to(since, y.shape), sweep], axis=-1)


class PlayStateStream:
    """:func:`play_state` one frame at a time, with the play operator itself: O(1) per frame.

    Parameters
    ----------
    shape : tuple of int
        Shape of one frame's edges (e.g. guides by sets by tendons).
    dt : float
        Sample period [s].
    """

    def __init__(self, shape: tuple[int, ...], dt: float):
        self.shape = tuple(shape)
        self.dt = float(dt)
        self.reset()

    def reset(self) -> None:
        """The next frame starts a trajectory: the output starts on the forward-slip edge."""
        self.y = np.zeros(self.shape)
        self.since = np.zeros(self.shape)  # frames since the last slip (or the start)
        self.x_max = np.zeros(self.shape)
        self.x_min = np.zeros(self.shape)
        self.started = False

    def step(self, lo: NDArray, hi: NDArray) -> tuple[NDArray, NDArray]:
        """One frame: the play operator's output [ln N] and its state, shape ``shape + (4,)``."""
        x = 0.5 * (lo + hi)
        if not self.started:
            y = np.array(lo, dtype=float, copy=True)  # a reset is the constant map y = lo
            self.since[...] = 0.0
            self.x_max, self.x_min = x.copy(), x.copy()
            self.started = True
        else:
            y = np.minimum(np.maximum(self.y, lo), hi)
            self.since = np.where(np.abs(y - self.y) > TOL, 0.0, self.since + 1.0)
            self.x_max, self.x_min = np.maximum(self.x_max, x), np.minimum(self.x_min, x)
        self.y = y
        sigma, position = _sigma_position(y, lo, hi)
        since = np.log1p(self.since * self.dt / SINCE_SLIP_SCALE)
        return y, np.stack([sigma, position, since, _sweep(self.x_max, self.x_min, lo, hi)], axis=-1)
