"""Statistics of held-out residuals: block bootstrap, whiteness and the noise floor."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tendon_id.diagnosis.splits import MeasurementNoise


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


def improvement_ci(
    e_before: NDArray, e_after: NDArray, block: int, n_boot: int, level: float, rng: np.random.Generator
) -> tuple[float, float]:
    """Block-bootstrap interval of the drop in held-out mean squared error [N^2] from one model to another.

    Frames where either residual is NaN (a model's warm-up) are left out; each frame's drop
    is the mean over its tendons.
    """
    sq = e_before**2 - e_after**2
    ok = np.isfinite(sq).all(axis=1)
    return bootstrap_ci(sq[ok].mean(axis=1), block, n_boot, level, rng)


def gap_closed(mse0: float, mse: float, floor: float) -> float:
    """Share of the base's mean squared error ``mse0`` above the noise floor [N] that a model removes [-]."""
    gap = mse0 - floor**2
    return float((mse0 - mse) / gap) if gap > 0 else 0.0


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


@dataclass(frozen=True)
class NoiseFloor:
    """What a perfect model's held-out error would be, given the sensors.

    Attributes
    ----------
    rmse : float
        Expected RMS error of a perfect model [N] (the floor the gap is measured from).
    upper : float
        Its ``level`` quantile over simulated measurement draws [N]: a base whose error is
        below this (plus ``min_excess``) is within what the sensors alone can produce.
    source : str
        Where the figure comes from.
    """

    rmse: float
    upper: float
    source: str


def _smooth(x: NDArray, inputs, width: int, *, median: bool = False) -> NDArray:
    """Moving average (or running median) of ``width`` frames along time, within each trajectory.

    The running median (Tukey 1977) keeps the steps of a step-and-hold protocol sharp,
    where a moving average would ramp through them; on a monotone ramp both return it.
    """
    from scipy.ndimage import median_filter, uniform_filter1d

    out = x.copy()
    for a, b in inputs.trajectory_bounds:
        if median:
            out[a:b] = median_filter(x[a:b], size=(width,) + (1,) * (x.ndim - 1), mode="nearest")
        else:
            out[a:b] = uniform_filter1d(x[a:b], size=width, axis=0, mode="nearest")
    return out


def difference_floor(residual: NDArray) -> NoiseFloor:
    """The noise floor from the residual's first differences (von Neumann 1941), without sensor metadata.

    A model error that varies slowly next to the noise cancels in them, so
    ``floor = std(diff(e)) / sqrt(2)``; it has no spread (``upper = rmse``). NaN frames (a
    model's warm-up) are left out.
    """
    f = float(np.nanstd(np.diff(residual, axis=0)) / np.sqrt(2.0))
    return NoiseFloor(f, f, "first differences of the residual")


def noise_floor(
    sensors: MeasurementNoise, model, inputs, residual: NDArray, rng, *, draws: int = 20, level: float = 0.95
) -> NoiseFloor:
    """The held-out error of a perfect model on these frames, by simulating the sensors.

    A model is fed measured inputs, so even the true one errs by more than the terminal
    cell's noise ``sigma``.  A play operator does not pass input errors like a ratio does:
    a noise spike or an encoder step that moves a stick band edge past the tension drags
    the output along and it stays there (a ratchet), so the inherited error is heavy-tailed
    and varies much from one realisation to the next.  It is therefore simulated: from
    estimates of the clean signals (the actuator cells' running median over 1 s, the angles'
    average over 3 frames, within each trajectory) each of ``draws`` draws adds ``sigma`` of cell noise
    and re-reads the angles on the encoder grid at a random offset (a quantum is a function
    of the true angle, :class:`~tendon_id.sim.Sensors`), and the model's prediction is
    compared with its prediction from the clean estimates.  A draw's mean squared error is
    ``sigma^2 + mean(dT^2)``; ``rmse`` is the root of their mean, ``upper`` of their
    ``level`` quantile.  (On ``snake12-noise-only`` with a nonsmooth capstan, the true
    law's inherited error was 1.0–1.8 N over ten realisations, and the draws spread over
    0.9–1.7 N: one realisation is compared with the quantile, not the mean.)

    Without a load-cell noise in the metadata, the floor comes from the residual's first
    differences (von Neumann 1941): a model error that varies slowly next to the noise
    cancels in them, so ``floor = std(diff(e)) / sqrt(2)``; it has no spread (``upper = rmse``).

    Parameters
    ----------
    sensors : MeasurementNoise
        Load-cell noise [N] and encoder quantum [rad] from the metadata.
    model : CapstanModel
        Fitted base model.
    inputs : TransmissionInputs
        Held-out frames.
    residual : ndarray, shape (T, 3)
        The base's held-out residual [N].
    rng : numpy.random.Generator
    draws : int
        Simulated measurement draws.
    level : float
        Quantile of ``upper``.
    """
    sigma = sensors.load_cell
    if sigma is None or not sigma > 0:
        return difference_floor(residual)
    actuator = _smooth(inputs.actuator, inputs, max(int(round(1.0 / inputs.dt)) | 1, 3), median=True)
    step = sensors.encoder_step
    angles = _smooth(inputs.angles, inputs, 3) if step else inputs.angles
    law = (model.A_, model.B_, model.block_params_)
    clean = model.terminal_reading(dataclasses.replace(inputs, actuator=actuator, angles=angles), *law)
    mse = np.empty(draws)
    for k in range(draws):
        noisy = np.maximum(actuator + sigma * rng.standard_normal(actuator.shape), 1e-3)
        read = angles
        if step:
            offset = rng.uniform(0.0, step, size=angles.shape[1:])
            read = np.round((angles + offset) / step) * step - offset
        shaken = model.terminal_reading(dataclasses.replace(inputs, actuator=noisy, angles=read), *law)
        mse[k] = sigma**2 + np.mean((shaken - clean) ** 2)
    source = "metadata (load-cell noise" + (", encoder quantum)" if step else ")")
    return NoiseFloor(float(np.sqrt(mse.mean())), float(np.sqrt(np.quantile(mse, level))), source)
