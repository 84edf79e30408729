"""Step-response metrics of Table III: rise time, settling time on a band, RMS error.

Rise and settling times come from python-control's ``step_info``.  It assumes a response that
starts at 0 and ignores ``final_output=0``, so a return to zero (loop 2) is handed to it as
the distance travelled from the commanded start, ``y' = y_start - y``, which starts at 0 and
ends at the step's size like loop 1.  Two more departures from its defaults:

* the settling band is absolute (the paper's +-0.5 deg), so ``SettlingTimeThreshold`` is the
  band over the commanded step (``step_info`` takes a fraction of the final value), and the
  final value is the commanded amplitude, not the last sample;
* a response that never reaches 90 % of the step has no rise time, and one still outside the
  band at its last sample has no settling time: ``None``, never a made-up number
  (``step_info`` raises on the first and returns NaN on the second).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["StepMetrics", "rms_error", "step_metrics"]


@dataclass(frozen=True)
class StepMetrics:
    """Rise time (10-90 %) [s] and settling time [s] from the step instant; None where not reached."""

    rise_s: float | None
    settle_s: float | None


def step_metrics(t: NDArray, y: NDArray, start: float, target: float, band: float) -> StepMetrics:
    """Metrics of one scalar step response.

    Parameters
    ----------
    t : ndarray, shape (T,)
        Sample times from the step instant [s] (``t[0] = 0``).
    y : ndarray, shape (T,)
        The response (any unit, here degrees).
    start, target : float
        Commanded value before and after the step.
    band : float
        Half-width of the settling band, in ``y``'s unit (0.5 deg in the paper).
    """
    import control  # python-control, a dependency; imported here to keep `tendon-id --help` light

    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    size = float(target) - float(start)
    if size == 0:
        raise ValueError("a step needs target != start")
    travelled = (y - start) * np.sign(size)  # from 0 towards |size|: the form step_info assumes
    amplitude = abs(size)
    if not np.any(travelled >= 0.9 * amplitude):
        # step_info cannot time a rise that never ends; the band (here wider than 10 % of the
        # step) may still hold the response: its rule, the sample after the last one outside
        outside = np.flatnonzero(np.abs(travelled - amplitude) >= band)
        settled_at = 0 if outside.size == 0 else outside[-1] + 1
        return StepMetrics(rise_s=None, settle_s=float(t[settled_at]) if settled_at < len(t) else None)
    info = control.step_info(
        travelled, t, final_output=amplitude, SettlingTimeThreshold=band / amplitude, RiseTimeLimits=(0.1, 0.9)
    )
    settle = float(info["SettlingTime"])
    return StepMetrics(rise_s=float(info["RiseTime"]), settle_s=settle if np.isfinite(settle) else None)


def rms_error(y: NDArray, ref: NDArray) -> float:
    """Root-mean-square tracking error over every sample and axis (``y``'s unit)."""
    return float(np.sqrt(np.mean((np.asarray(y) - np.asarray(ref)) ** 2)))
