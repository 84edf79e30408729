"""The learned cascade under both tyings: tied against per-guide PG-CHTC networks (:doc:`/guide/identifiability`).

Terminal labels do not pin down how the friction splits along the robot, so networks
trained from different seeds are free to disagree at the intermediate joints: the spread
over seeds measures that freedom, the error against simulator truth (where there is
some) measures what it costs.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from tendon_id.data import Recording
from tendon_id.metrics import tendon_metrics
from tendon_id.zoo.registry import make


def learned_comparison(
    views: Sequence[Recording],
    truth: NDArray | None,
    *,
    seeds: int = 3,
    preset: str = "fast",
    progress: bool | None = None,
) -> dict:
    """Tied against per-guide PG-CHTC: intermediate-joint error against truth and the spread over seeds.

    Both are trained on the same terminal labels (fast preset by default); the spread is the
    sd over seeds of the joint-side estimates, averaged over frames, tendons and the
    intermediate joints [N]: where the terminal data do not pin the split of the friction
    along the robot, differently seeded networks disagree there.

    Parameters
    ----------
    views : sequence of Recording
        Training data without intermediate truth.
    truth : ndarray, shape (T, N, n), or None
        Joint-side truth [N] to score against, ``n`` tendons per set (None: no error is reported).
    seeds, preset : int, str
        Seeds per tying and the PG-CHTC preset.
    progress : bool, optional

    Returns
    -------
    dict
        ``{"tied": ..., "per_guide": ...}``, each with ``joint_rmse`` per seed [N], its mean, and the
        seed spread ``seed_spread_mean_n`` / ``seed_spread_per_joint_n`` [N].
    """
    out = {}
    for tied in (True, False):
        preds, rmse = [], []
        for s in range(seeds):
            m = make("pg-chtc", preset=preset, tied=tied, seed=s, progress=progress).fit(views)
            p = m.predict(views)
            preds.append(p)
            if truth is not None:
                inner = range(1, p.shape[1] - 1)
                rmse.append(float(np.mean([tendon_metrics(p[:, j], truth[:, j])["rmse"] for j in inner])))
        preds = np.stack(preds)
        spread = preds.std(axis=0, ddof=1) if seeds > 1 else np.zeros(preds.shape[1:])
        out["tied" if tied else "per_guide"] = {
            "seeds": seeds,
            "preset": preset,
            "joint_rmse": rmse or None,
            "joint_rmse_mean": float(np.mean(rmse)) if rmse else None,
            "seed_spread_mean_n": float(spread[:, 1:-1].mean()),
            "seed_spread_per_joint_n": [float(x) for x in spread.mean(axis=(0, 2))],
        }
    return out
