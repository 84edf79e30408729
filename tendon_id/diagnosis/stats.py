"""Statistics of held-out residuals: block bootstrap, whiteness and the noise floor."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tendon_id.diagnosis.moments import nan_std_of_differences
from tendon_id.family.inputs import frame_slices


def block_bootstrap_means(
    x: NDArray, block: int, n_boot: int, rng: np.random.Generator, overwrite_input: bool = False
) -> NDArray[np.float64]:
    """Means of ``n_boot`` moving-block bootstrap resamples of the series ``x`` (Künsch 1989).

    Blocks of ``block`` consecutive values are drawn with replacement until the resample is
    as long as ``x``, which keeps the series' short-range correlation in every resample.
    ``overwrite_input=True`` lets the cumulative sums take ``x``'s place (a float64 array of
    the caller's own, not read again): at an hour of logging that is 27 MiB not allocated.
    """
    x = np.asarray(x, dtype=float)
    n = len(x)
    if n == 0:
        return np.full(n_boot, np.nan)
    block = int(min(max(block, 1), n))
    n_blocks = -(-n // block)
    # Block sums by cumulative sums: each resample is a sum of n_blocks block sums (the last trimmed).
    # csum[i] is the sum of x[:i], 0 at i = 0: read from cumsum's c[i - 1], so no array of n + 1.
    own = overwrite_input and x.flags.writeable and x.flags.c_contiguous and x.ndim == 1
    c = np.cumsum(x, out=x if own else None)

    def csum(i):
        return np.where(i > 0, c[np.maximum(i - 1, 0)], 0.0)

    starts = rng.integers(0, n - block + 1, size=(n_boot, n_blocks))
    sums = c[starts + block - 1] - csum(starts)
    last = n - block * (n_blocks - 1)
    sums[:, -1] = c[starts[:, -1] + last - 1] - csum(starts[:, -1])
    return sums.sum(axis=1) / n


def bootstrap_ci(
    x: NDArray, block: int, n_boot: int, level: float, rng: np.random.Generator, overwrite_input: bool = False
) -> tuple[float, float]:
    """Percentile interval of the mean of ``x`` at two-sided ``level`` by :func:`block_bootstrap_means`."""
    means = block_bootstrap_means(x, block, n_boot, rng, overwrite_input=overwrite_input)
    tail = 50.0 * (1.0 - level)
    lo, hi = np.percentile(means, [tail, 100.0 - tail])
    return float(lo), float(hi)


def improvement_ci(
    e_before: NDArray, e_after: NDArray, block: int, n_boot: int, level: float, rng: np.random.Generator
) -> tuple[float, float]:
    """Block-bootstrap interval of the drop in held-out mean squared error [N^2] from one model to another.

    Frames where either residual is NaN (a model's warm-up) are left out; each frame's drop
    is the mean over its tendons.
    """
    return bootstrap_ci(frame_drops(e_before, e_after), block, n_boot, level, rng, overwrite_input=True)


def frame_drops(e_before: NDArray, e_after: NDArray) -> NDArray[np.float64]:
    """Each frame's drop in squared error, the mean over its channels, shape (T',): frames with a NaN left out."""

    def part(s):
        sq = np.square(e_before[s])
        sq -= np.square(e_after[s])
        return sq

    return _finite_frame_means(len(e_before), part)


def frame_mean_squares(e: NDArray) -> NDArray[np.float64]:
    """Each frame's squared error, the mean over its channels, shape (T',): frames with a NaN left out."""
    return _finite_frame_means(len(e), lambda s: np.square(e[s]))


def _finite_frame_means(n: int, part) -> NDArray[np.float64]:
    """Row means of ``part(s)`` over frame slices ``s``, rows with a non-finite value left out, in one array.

    Slice by slice: whole-length squares would be three more copies at an hour of logging, and the
    result the same bits (each row's values, and its mean, are the same).
    """
    out = np.empty(n)
    kept = 0
    for s in frame_slices(n):
        v = part(s)
        v = v[np.isfinite(v).all(axis=1)].mean(axis=1)
        out[kept : kept + len(v)] = v
        kept += len(v)
    return out[:kept]


def gap_closed(mse0: float, mse: float, floor: float) -> float:
    """Share of the base's mean squared error ``mse0`` above the noise floor [N] that a model removes [-]."""
    gap = mse0 - floor**2
    return float((mse0 - mse) / gap) if gap > 0 else 0.0


def ljung_box_p(residual: NDArray, lags: int = 10) -> list[float]:
    """Ljung–Box p-value of each column of ``residual`` (Ljung & Box 1978).

    ``Q = n (n + 2) sum_k r_k^2 / (n - k)`` over lags ``k = 1..lags``, against chi^2 with
    ``lags`` degrees of freedom: a small p-value says the residual is not white, something
    systematic is left.  ``r_k = sum_t x_t x_{t+k} / sum_t x_t^2`` of the demeaned series
    (statsmodels' ``acf``, Box, Jenkins & Reinsel 2008, Eq. 2.1.12), one dot product of two
    views per lag: O(n lags) time and no memory beyond the demeaned copy, where an FFT's
    padded complex buffers held several times the series (issue 42's scale), and
    ``acorr_ljungbox``'s correlation over every lag took 400 s on a million frames (the same
    statistic; a test checks the three agree).
    """
    from scipy.stats import chi2

    k = np.arange(1, lags + 1)
    out = []
    for col in np.atleast_2d(np.asarray(residual, dtype=float).T):
        col = col[np.isfinite(col)]
        n = len(col)
        if n <= lags + 1 or col.min() == col.max():  # constant: no correlation (no copy, as np.std would make)
            out.append(float("nan"))
            continue
        x = col  # a copy of our own (the finite frames): demeaned in place, not copied again
        x -= col.mean()
        r = np.array([np.dot(x[:-j], x[j:]) for j in k]) / np.dot(x, x)
        q = n * (n + 2) * float(np.sum(r**2 / (n - k)))
        out.append(float(chi2.sf(q, lags)))
    return out


@dataclass(frozen=True)
class NoiseFloor:
    """What a perfect model's held-out error would be, given the sensors.

    Attributes
    ----------
    rmse : float
        Expected RMS error of a perfect model [N or the family's unit] (the floor the gap is
        measured from).
    upper : float
        Its ``level`` quantile over simulated measurement draws, where the family simulates
        them (else ``rmse``): a base whose error is below this (plus ``min_excess``) is within
        what the sensors alone can produce.
    source : str
        Where the figure comes from.
    """

    rmse: float
    upper: float
    source: str


def difference_floor(residual: NDArray) -> NoiseFloor:
    """The noise floor from the residual's first differences (von Neumann 1941), without sensor metadata.

    A model error that varies slowly next to the noise cancels in them, so
    ``floor = std(diff(e)) / sqrt(2)``; it has no spread (``upper = rmse``). NaN frames (a
    model's warm-up) are left out.
    """
    f = nan_std_of_differences(residual) / np.sqrt(2.0)
    return NoiseFloor(f, f, "first differences of the residual")
