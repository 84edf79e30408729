"""The intermediate-tension ambiguity band (:doc:`/guide/identifiability`).

For each joint, the spread of the joint-side estimates over the laws that fit the
terminal data equally well: the posterior draws of
:func:`~tendon_id.identifiability.sampler.hit_and_run`, pushed through the
cascade (paper Algorithm 1 with analytic ratios).  The band is predictive for the
*true* joint-side tension: the estimate starts from the *measured* actuator
tension, so the actuator load cell's noise (``noise_n``) is added in the log
domain, ``ln T[1, j]`` having sd ``noise_n / T[1, j]`` (delta method).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration.problem import LawProblem


@dataclass
class Band:
    """Lower and upper edges of the 95 % band and its median, per frame, joint and tendon [N].

    Attributes
    ----------
    frames : ndarray of int
        The frames of the recording the band is evaluated on.
    lo, median, hi : ndarray, shape (F, N, n)
    """

    frames: NDArray[np.int64]
    lo: NDArray[np.float64]
    median: NDArray[np.float64]
    hi: NDArray[np.float64]

    @property
    def width(self) -> NDArray[np.float64]:
        return self.hi - self.lo

    def mean_width(self, joints: slice | None = None) -> float:
        """Mean width over frames, tendons and the intermediate joints ``2..N-1`` by default [N]."""
        j = slice(1, -1) if joints is None else joints
        return float(np.mean(self.width[:, j]))

    def per_joint_width(self) -> NDArray[np.float64]:
        """Mean width per joint (1..N) [N]."""
        return self.width.mean(axis=(0, 2))

    def coverage(self, truth: NDArray) -> NDArray[np.float64]:
        """Fraction of frames and tendons whose truth (T, N, n) lies inside the band, per joint."""
        t = truth[self.frames]
        return np.mean((t >= self.lo) & (t <= self.hi), axis=(0, 2))

    def rmse(self, truth: NDArray, joints: slice | None = None) -> float:
        """RMSE [N] of the band's median against the truth (T, N, n), intermediate joints ``2..N-1`` by default."""
        j = slice(1, -1) if joints is None else joints
        return float(np.sqrt(np.mean((self.median[:, j] - truth[self.frames][:, j]) ** 2)))

    def scores(self, truth: NDArray | None) -> dict:
        """Mean width [N], and where truth is given its coverage and the median's RMSE [N], at joints ``2..N-1``."""
        out = {"band_width_mean": self.mean_width(), "truth_coverage": None, "rmse_n": None}
        if truth is not None:
            out["truth_coverage"] = float(np.mean(self.coverage(truth)[1:-1]))
            out["rmse_n"] = self.rmse(truth)
        return out


def band_frames(n_frames: int, max_frames: int, seed: int) -> NDArray[np.int64]:
    """Frames the band is evaluated on: all, or an evenly spread, seeded subset."""
    if n_frames <= max_frames:
        return np.arange(n_frames)
    rng = np.random.default_rng(seed)
    return np.sort(rng.choice(n_frames, size=max_frames, replace=False))


#: Law draws pushed through the cascade per tendon (a seeded subset of the sampler's).
BAND_DRAWS = 500


def ambiguity_band(
    problem: LawProblem,
    draws: list[NDArray],
    frames: NDArray,
    *,
    noise_n: float | None = None,
    quantiles: tuple[float, float] = (2.5, 97.5),
    seed: int = 0,
    max_draws: int = BAND_DRAWS,
) -> Band:
    """Band of the joint-side tensions over law draws.

    Parameters
    ----------
    problem : LawProblem
    draws : list of ndarray
        Per tendon, law draws of shape (D, p).
    frames : ndarray of int
        Frames to evaluate.
    noise_n : float, optional
        Actuator load-cell noise [N] added in the log domain (default: the problem's nominal).
    max_draws : int
        At most this many draws per tendon are used (a seeded random subset).
    """
    rng = np.random.default_rng(seed)
    noise = problem.noise_n if noise_n is None else float(noise_n)
    act = problem.inputs.actuator[frames]  # (F, N, n)
    lo = np.empty(act.shape)
    med = np.empty(act.shape)
    hi = np.empty(act.shape)
    for i, th in enumerate(draws):
        if len(th) > max_draws:
            th = th[np.sort(rng.choice(len(th), size=max_draws, replace=False))]
        expo = problem.joint_exponents(th, frames)  # (D, F, N)
        log_t = np.log(act[None, :, :, i]) - expo
        log_t += rng.standard_normal(log_t.shape) * (noise / act[None, :, :, i])
        q = np.exp(np.percentile(log_t, [quantiles[0], 50.0, quantiles[1]], axis=0))
        lo[..., i], med[..., i], hi[..., i] = q
    return Band(frames=np.asarray(frames), lo=lo, median=med, hi=hi)
