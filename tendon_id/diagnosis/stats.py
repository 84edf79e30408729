"""Statistics of held-out residuals: block bootstrap, whiteness and the noise floor."""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import NDArray


def block_bootstrap_means(x: NDArray, block: int, n_boot: int, rng: np.random.Generator) -> NDArray[np.float64]:
    """Means of ``n_boot`` moving-block bootstrap resamples of the series ``x`` (Künsch 1989).

    Blocks of ``block`` consecutive values are drawn with replacement until the resample is
    as long as ``x``, which keeps the series' short-range correlation in every resample.
    """
    x = np.asarray(x, dtype=float)
    n = len(x)
    if n == 0:
        return np.full(n_boot, np.nan)
    block = int(min(max(block, 1), n))
    n_blocks = -(-n // block)
    # Block sums by cumulative sums: each resample is a sum of n_blocks block sums (the last trimmed).
    csum = np.r_[0.0, np.cumsum(x)]
    starts = rng.integers(0, n - block + 1, size=(n_boot, n_blocks))
    sums = csum[starts + block] - csum[starts]
    last = n - block * (n_blocks - 1)
    sums[:, -1] = csum[starts[:, -1] + last] - csum[starts[:, -1]]
    return sums.sum(axis=1) / n


def bootstrap_ci(x: NDArray, block: int, n_boot: int, level: float, rng: np.random.Generator) -> tuple[float, float]:
    """Percentile interval of the mean of ``x`` at two-sided ``level`` by :func:`block_bootstrap_means`."""
    means = block_bootstrap_means(x, block, n_boot, rng)
    tail = 50.0 * (1.0 - level)
    lo, hi = np.percentile(means, [tail, 100.0 - tail])
    return float(lo), float(hi)


def ljung_box_p(residual: NDArray, lags: int = 10) -> list[float]:
    """Ljung–Box p-value of each column of ``residual`` (statsmodels; Ljung & Box 1978).

    A small p-value says the residual is not white: something systematic is left.
    """
    from statsmodels.stats.diagnostic import acorr_ljungbox

    out = []
    for col in np.atleast_2d(np.asarray(residual, dtype=float).T):
        col = col[np.isfinite(col)]
        if len(col) <= lags + 1 or np.std(col) == 0:
            out.append(float("nan"))
            continue
        out.append(float(acorr_ljungbox(col - col.mean(), lags=[lags])["lb_pvalue"].iloc[0]))
    return out


def noise_floor(meta_noise: float | None, model, inputs, residual: NDArray, rng) -> tuple[float, str]:
    """RMS error [N] of a perfect model on these frames, and where the figure comes from.

    With the load-cell noise ``sigma`` from the recordings' metadata, two parts:

    * the terminal reading's own noise, ``sigma``;
    * the noise the prediction inherits from the actuator cells.  A play operator does not
      pass input noise like a ratio does: each noise spike past a stick band drags the
      output along and it stays there (a ratchet).  So that part is measured by running the
      model on an estimate of the clean actuator signal (a 1 s moving average within each
      trajectory) with and without ``sigma`` of added noise; the RMS change of its
      prediction is the inherited noise.  (The average also smooths real motion, so this is
      an estimate; on ``snake12-paper``'s physics it is within 2 % of the error of the true
      model.)

    ``floor^2 = sigma^2 + mean(dT_hat^2)``.  Without metadata, the floor comes from the
    residual's first differences (von Neumann 1941): a model error that varies slowly next
    to the noise cancels in them, so ``floor = std(diff(e)) / sqrt(2)``.

    Parameters
    ----------
    meta_noise : float or None
        Load-cell noise [N].
    model : CapstanModel
        Fitted base model.
    inputs : TransmissionInputs
        Held-out frames.
    residual : ndarray, shape (T, 3)
        The base's held-out residual [N].
    rng : numpy.random.Generator
    """
    if meta_noise is not None and meta_noise > 0:
        from scipy.ndimage import uniform_filter1d

        width = max(int(round(1.0 / inputs.dt)) | 1, 3)
        smooth = inputs.actuator.copy()
        for a, b in inputs.trajectory_bounds:
            smooth[a:b] = uniform_filter1d(inputs.actuator[a:b], size=width, axis=0, mode="nearest")
        noisy = np.maximum(smooth + meta_noise * rng.standard_normal(smooth.shape), 1e-3)
        law = (model.A_, model.B_, model.block_params_)
        clean = model.terminal_reading(dataclasses.replace(inputs, actuator=smooth), *law)
        shaken = model.terminal_reading(dataclasses.replace(inputs, actuator=noisy), *law)
        return float(np.sqrt(meta_noise**2 + np.mean((shaken - clean) ** 2))), "metadata (load-cell noise)"
    d = np.diff(residual, axis=0)
    return float(np.nanstd(d) / np.sqrt(2.0)), "first differences of the residual"
