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

import numpy as np
from numpy.typing import NDArray

from tendon_id.errors import NonFiniteResult
from tendon_id.family.inputs import frame_slices

#: Why a statistic of a residual with no finite value is refused rather than NaN.
NO_FINITE = (
    "the held-out residual has no finite value (a warm-up as long as the held-out data, or a model "
    "that diverged on it): its error is undefined"
)

__all__ = ["nan_mean_square", "nan_pearson", "nan_std_of_differences", "nan_sum_square"]


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
    """``nanmean(x**2)`` over every entry of ``x``.

    Raises
    ------
    NonFiniteResult
        Where no entry is finite: the mean is undefined, never a NaN result.
    """
    total, count = _sum_square(x)
    if not count:
        raise NonFiniteResult(NO_FINITE)
    return total / count


def nan_std_of_differences(x: NDArray) -> float:
    """``nanstd(diff(x, axis=0))`` (ddof 0), each slice's differences made from it and its last frame before.

    Two passes: the differences' mean, then their squared deviations from it.

    Raises
    ------
    NonFiniteResult
        Where no difference is finite.
    """
    x = np.asarray(x, dtype=float)

    def differences():
        return (x[s.start + 1 : s.stop + 1] - x[s] for s in frame_slices(len(x) - 1))

    total, count = 0.0, 0
    for d in differences():
        ok = np.isfinite(d)
        total += float(np.sum(d, where=ok))
        count += int(ok.sum())
    if not count:
        raise NonFiniteResult(NO_FINITE)
    mean, spread = total / count, 0.0
    for d in differences():
        d = np.subtract(d, mean, where=np.isfinite(d), out=np.zeros(d.shape))
        spread += float(np.dot(d.ravel(), d.ravel()))
    return float(np.sqrt(spread / count))


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
