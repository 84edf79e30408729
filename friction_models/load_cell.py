"""Signal operations of a real load cell's measurement chain: calibration errors, lag and sampling instant.

Each function works on a signal with time on axis 0 and is vectorised over the trailing axes (sets,
tendons).  ``reset`` marks the first frame of each segment (trajectory): a segment is read on its
own, and frame 0 always starts one.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from friction_models.scan import affine_prefix


def gain_offset(tension: ArrayLike, gain: ArrayLike, offset: ArrayLike) -> NDArray[np.float64]:
    """A load cell's calibration error: ``(1 + gain) T + offset``.

    Parameters
    ----------
    tension : array_like
        True tension [N], any shape.
    gain : array_like
        Relative gain (span) error [-], ``> -1``, broadcast against ``tension``.
    offset : array_like
        Zero offset [N], broadcast against ``tension``.

    Returns
    -------
    ndarray
        The reading [N] before noise.
    """
    g = np.asarray(gain, dtype=float)
    if np.any(g <= -1.0):
        raise ValueError("a gain error must be > -1 (a cell that reads its load upside down or not at all)")
    return (1.0 + g) * np.asarray(tension, dtype=float) + np.asarray(offset, dtype=float)


def _segments(n: int, reset: ArrayLike | None) -> NDArray[np.bool_]:
    r = np.zeros(n, dtype=bool) if reset is None else np.asarray(reset, dtype=bool).copy()
    if r.shape != (n,):
        raise ValueError(f"reset needs one flag per frame, shape ({n},), got {r.shape}")
    if n:
        r[0] = True
    return r


def first_order_lowpass(x: ArrayLike, dt: float, tau: float, reset: ArrayLike | None = None) -> NDArray[np.float64]:
    """First-order low-pass of a sampled signal, the exact step of ``tau y' + y = x``.

    With the input held over each frame period (zero-order hold),

        y[t] = a y[t-1] + (1 - a) x[t],   a = exp(-dt / tau),

    so a unit step reaches ``1 - exp(-k dt / tau)`` after ``k`` frames, ``1 - exp(-1)`` after ``tau``.
    At each reset the filter starts settled on its input, ``y = x``: the segment was preceded by
    a hold long against ``tau``.

    Parameters
    ----------
    x : array_like, shape (T, ...)
        Input [any unit], time on axis 0.
    dt : float
        Sample period [s], ``> 0``.
    tau : float
        Time constant [s], ``> 0``.
    reset : array_like of bool, shape (T,), optional
        True at the first frame of each segment; frame 0 always is.

    Returns
    -------
    ndarray, shape (T, ...)
        The filtered signal.
    """
    if not (dt > 0 and tau > 0):
        raise ValueError("dt and tau must be positive times in s")
    x = np.asarray(x, dtype=float)
    if x.shape[0] == 0:
        return x.copy()
    r = _segments(x.shape[0], reset)
    a_step = np.exp(-dt / tau)
    a = np.full(x.shape, a_step)
    b = (1.0 - a_step) * x
    a[r] = 0.0
    b[r] = x[r]
    _, y = affine_prefix(a, b)  # y(-1) is irrelevant: frame 0 is a reset
    return y


def shifted_read(x: ArrayLike, shift: float, reset: ArrayLike | None = None) -> NDArray[np.float64]:
    """Read a sampled signal ``shift`` frames off its own time stamps, by linear interpolation.

    Frame ``t`` of the result is the signal at ``t + shift`` (a fraction allowed): a positive shift
    reads later than the time stamp says, a negative one earlier.  Between two frames of a segment
    the signal is interpolated linearly (exact for a ramp; second order in the frame period for a
    smooth quasi-static signal); beyond a segment's first or last frame it is held at that frame's
    value.  A whole-frame shift (to within 1e-9 of a frame, as one given in seconds over the frame
    period comes out) is an exact shift of the samples.

    Parameters
    ----------
    x : array_like, shape (T, ...)
        Signal, time on axis 0.
    shift : float
        Read-out instant relative to the time stamp [frames], finite.
    reset : array_like of bool, shape (T,), optional
        True at the first frame of each segment; frame 0 always is.

    Returns
    -------
    ndarray, shape (T, ...)
    """
    shift = float(shift)
    if not np.isfinite(shift):
        raise ValueError(f"shift must be a finite number of frames, got {shift}")
    if abs(shift - round(shift)) < 1e-9:  # a shift given in seconds over a frame period: whole frames, exactly
        shift = float(round(shift))
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    if n == 0 or shift == 0.0:
        return x.copy()
    r = _segments(n, reset)
    starts = np.flatnonzero(r)
    ends = np.r_[starts[1:], n] - 1
    seg = np.cumsum(r) - 1
    lo, hi = starts[seg], ends[seg]
    p = np.clip(np.arange(n) + shift, lo, hi)
    i0 = np.floor(p).astype(np.intp)
    f = (p - i0).reshape((n,) + (1,) * (x.ndim - 1))
    i1 = np.minimum(i0 + 1, hi)
    return x[i0] * (1.0 - f) + x[i1] * f


def first_order_inverse(y: NDArray, dt: float, tau: float, reset: NDArray | None = None) -> NDArray:
    """The input of :func:`first_order_lowpass` from its output: the lag undone, exactly.

    ``x[t] = (y[t] - a y[t-1]) / (1 - a)``, ``a = exp(-dt / tau)``, and ``x = y`` at each reset,
    where the filter starts settled on its input.  ``tau = 0`` returns ``y`` itself.

    Parameters
    ----------
    y : ndarray, shape (T, ...)
        Lagged signal, time on axis 0.
    dt : float
        Sample period [s], ``> 0``.
    tau : float
        Time constant [s], ``>= 0``.
    reset : ndarray of bool, shape (T,), optional
        True at the first frame of each segment; frame 0 always is.

    Returns
    -------
    ndarray, shape (T, ...)
    """
    if tau == 0.0:
        return y
    if not (dt > 0 and tau > 0):
        raise ValueError("dt and tau must be positive times in s")
    y = np.asarray(y, dtype=float)
    a = np.exp(-dt / tau)
    x = y.copy()
    x[1:] -= a * y[:-1]
    x[1:] /= 1.0 - a
    if reset is not None:
        r = np.asarray(reset, dtype=bool)
        x[r] = y[r]
    x[:1] = y[:1]
    return x
