"""Moments of whole-length residuals taken slice by slice: no temporary as long as the series.

At an hour of 1 kHz logging a residual is 27 MiB a channel, and numpy's ``nanmean(e**2)``,
``nanstd`` or ``corrcoef`` make two to four copies of it (the square, the NaN mask's
replacement, the stacked pair, its centred copy). Here each statistic is accumulated over
slices of :data:`~tendon_id.family.inputs.SLICE_FRAMES` frames, so a temporary is a slice long (issue 42's scale).

Means and variances are two-pass (the mean first, then the sum of squared deviations from
it), which keeps the variance as accurate as numpy's (Chan, Golub & LeVeque 1983, "Algorithms
for computing the sample variance", The American Statistician 37(3)); the sums differ from
numpy's pairwise ones only in rounding (``tests/diagnosis/test_moments.py`` checks them against numpy).
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from numpy.typing import NDArray

from tendon_id.family import inputs

__all__ = ["frame_slices", "nan_mean_square", "nan_pearson", "nan_std_of_differences", "nan_sum_square"]


def frame_slices(n: int) -> Iterator[slice]:
    """Consecutive slices of ``n`` frames, :data:`~tendon_id.family.inputs.SLICE_FRAMES` long (the last shorter)."""
    step = max(int(inputs.SLICE_FRAMES), 1)  # read when called: a test may shorten it
    for a in range(0, n, step):
        yield slice(a, min(a + step, n))


def _sum_square(x: NDArray) -> tuple[float, int]:
    """Sum of the squares of the finite entries of ``x``, and their count."""
    x = np.asarray(x, dtype=float)
    total, count = 0.0, 0
    for s in frame_slices(len(x)):
        part = x[s]
        ok = np.isfinite(part)
        total += float(np.sum(np.square(part, where=ok, out=np.zeros(part.shape))))
        count += int(ok.sum())
    return total, count


def nan_sum_square(x: NDArray) -> float:
    """``nansum(x**2)`` over every entry of ``x``."""
    return _sum_square(x)[0]


def nan_mean_square(x: NDArray) -> float:
    """``nanmean(x**2)`` over every entry of ``x``: NaN where no entry is finite."""
    total, count = _sum_square(x)
    return total / count if count else float("nan")


def _mean_and_spread(parts) -> tuple[float, float, int]:
    """Mean, sum of squared deviations and count of the finite values of a re-iterable of arrays."""
    total, count = 0.0, 0
    for part in parts():
        ok = np.isfinite(part)
        total += float(np.sum(part, where=ok))
        count += int(ok.sum())
    if count == 0:
        return float("nan"), float("nan"), 0
    mean = total / count
    spread = 0.0
    for part in parts():
        d = np.subtract(part, mean, where=np.isfinite(part), out=np.zeros(part.shape))
        spread += float(np.dot(d.ravel(), d.ravel()))
    return mean, spread, count


def nan_std_of_differences(x: NDArray) -> float:
    """``nanstd(diff(x, axis=0))`` (ddof 0), each slice's differences made from it and its last frame before."""
    x = np.asarray(x, dtype=float)
    n = len(x) - 1
    _, spread, count = _mean_and_spread(lambda: (x[s.start + 1 : s.stop + 1] - x[s] for s in frame_slices(n)))
    return float(np.sqrt(spread / count)) if count else float("nan")


def nan_pearson(x: NDArray, y: NDArray) -> float:
    """Pearson correlation of ``x`` and ``y`` (same shape) over the entries where both are finite.

    0 where either is constant there, or fewer than two entries are (what a correlation with
    a column that never moves says: nothing). Two passes over slices: the means, then the
    centred sums of squares and products.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.shape != y.shape:
        raise ValueError(f"x {x.shape} and y {y.shape} differ in shape")
    both = [np.isfinite(x[s]) & np.isfinite(y[s]) for s in frame_slices(len(x))]
    count = int(sum(int(b.sum()) for b in both))
    if count < 2:
        return 0.0
    slices = list(frame_slices(len(x)))
    for v in (x, y):  # exactly constant: no correlation (a mean's rounding would make up a spread)
        if max(float(np.max(v[s], where=b, initial=-np.inf)) for s, b in zip(slices, both)) == min(
            float(np.min(v[s], where=b, initial=np.inf)) for s, b in zip(slices, both)
        ):
            return 0.0
    mx = sum(float(np.sum(x[s], where=b)) for s, b in zip(slices, both)) / count
    my = sum(float(np.sum(y[s], where=b)) for s, b in zip(slices, both)) / count
    sxx = syy = sxy = 0.0
    for s, b in zip(slices, both):
        dx = np.subtract(x[s], mx, where=b, out=np.zeros(b.shape)).ravel()
        dy = np.subtract(y[s], my, where=b, out=np.zeros(b.shape)).ravel()
        sxx += float(np.dot(dx, dx))
        syy += float(np.dot(dy, dy))
        sxy += float(np.dot(dx, dy))
    if sxx <= 0.0 or syy <= 0.0:
        return 0.0
    return float(np.clip(sxy / np.sqrt(sxx * syy), -1.0, 1.0))
