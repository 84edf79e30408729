"""Metrics of the paper's tables (:doc:`/guide/zoo`): RMSE, R^2 and max error per tendon, averaged over tendons."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray


def tendon_metrics(pred: ArrayLike, true: ArrayLike) -> dict[str, float]:
    """RMSE [N], R^2 [-] and maximum absolute error [N], each per tendon then averaged.

    Parameters
    ----------
    pred, true : array_like, shape (T, n)
        Estimated and reference tensions [N] of a set's ``n`` tendons.

    Returns
    -------
    dict
        ``{"rmse", "r2", "max_error"}``, the metrics object ``M`` of :doc:`/cli`.
        R^2 is ``1 - SSE / SST`` per tendon (negative when worse than the mean), averaged over
        the tendons whose reference varies; it is NaN when none does (``SST = 0``: one frame,
        or a held load), since R^2 is then undefined.
    """
    p = np.asarray(pred, dtype=float)
    y = np.asarray(true, dtype=float)
    if p.shape != y.shape or p.ndim != 2:
        raise ValueError(f"pred and true must both be (T, n); got {p.shape} and {y.shape}")
    err = p - y
    rmse = np.sqrt(np.mean(err**2, axis=0))
    sst = np.sum((y - y.mean(axis=0)) ** 2, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        r2 = np.where(sst > 0, 1.0 - np.sum(err**2, axis=0) / sst, np.nan)
    return {
        "rmse": float(np.mean(rmse)),
        "r2": float(np.mean(r2[~np.isnan(r2)])) if not np.isnan(r2).all() else float("nan"),
        "max_error": float(np.mean(np.max(np.abs(err), axis=0))),
    }


def frame_weighted(metrics: Sequence[dict[str, float]], frames: Sequence[int]) -> dict[str, float]:
    """Overall metrics across protocols: each metric's mean weighted by frames.

    This is the paper's "Overall (frame-weighted)" column of Table II: its proximal
    row, 45.530 N and R^2 -0.502, is exactly the 800/500/1260-frame weighted mean
    of the three protocols' values.
    """
    w = np.asarray(frames, dtype=float)
    if w.size == 0 or w.sum() <= 0:
        raise ValueError("frame counts must be positive")
    w = w / w.sum()
    return {key: float(np.sum(w * np.array([m[key] for m in metrics]))) for key in ("rmse", "r2", "max_error")}


def jacobian_correlation(jac) -> NDArray | None:
    """Correlations of the parameters from the Gauss–Newton covariance ``(J^T J)^-1``, or None when it is singular.

    Near +-1 where the data cannot tell two parameters apart (a least-squares fit's Jacobian
    ``jac``, shape (residuals, parameters), dense or sparse).
    """
    J = jac.toarray() if hasattr(jac, "toarray") else np.asarray(jac)
    return gram_correlation(J.T @ J)


def gram_correlation(M) -> NDArray | None:
    """:func:`jacobian_correlation` from the Gram matrix ``J^T J`` (summed over windows of a long log)."""
    M = np.asarray(M, dtype=float)
    try:
        cov = np.linalg.inv(M)
    except np.linalg.LinAlgError:
        return None
    d = np.sqrt(np.abs(np.diag(cov)))
    if not np.all(d > 0) or not np.all(np.isfinite(d)):
        return None
    return cov / np.outer(d, d)
