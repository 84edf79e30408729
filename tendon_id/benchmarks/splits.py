"""The paper's data splits (Section IV-B), by trajectory, on a recipe's simulated protocols."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tendon_id.data import Recording
from tendon_id.datasets import load
from tendon_id.metrics import frame_weighted
from tendon_id.sim import Recipe

#: Held-out test trajectories per protocol: the paper's T = 800 / 500 / 1260 frames.
TEST_TRAJECTORIES = {"posterior-3": 4, "posterior-6": 4, "planned-paths": 4}
#: Training pool: all frames of the posterior protocols not held out, plus this many
#: terminal-only frames, so the pool is the paper's "23000 frames after downsampling".
TRAIN_FRAMES = 23000
TEST_PROTOCOLS = ("posterior-3", "posterior-6", "planned-paths")


@dataclass(frozen=True)
class PaperSplit:
    """Train (70 %), validation (30 %) and per-protocol test recordings.

    Attributes
    ----------
    train, val : Recording
        The mixed terminal-only / posterior-3 / posterior-6 pool, split by trajectory.
    test : dict of str to Recording
        Held-out posterior-3, posterior-6 and planned-paths trajectories; planned paths are
        never seen in training.
    """

    train: Recording
    val: Recording
    test: dict

    @property
    def calibration(self) -> Recording:
        """Train plus validation: what the analytic baselines are calibrated on."""
        return Recording.concat([self.train, self.val])


def _full_length(rec: Recording) -> list[str]:
    counts = {t: int(np.sum(rec.trajectory_ids == t)) for t in rec.trajectories}
    longest = max(counts.values())
    return [t for t, c in counts.items() if c == longest]


def paper_split(
    recipe: str | Recipe = "snake12-paper",
    seed: int = 0,
    *,
    train_frames: int = TRAIN_FRAMES,
    progress: bool | None = None,
) -> PaperSplit:
    """Build the Section IV-B split of a recipe (cached datasets, seeded choice of test trajectories).

    ``train_frames`` is the training pool's size [frames] (the paper's 23 000 by default).
    """
    rng = np.random.default_rng(seed)
    recs = {p: load(recipe, protocol=p, progress=progress) for p in ("terminal-only",) + TEST_PROTOCOLS}
    test, pool = {}, []
    for p in TEST_PROTOCOLS:
        held = list(rng.choice(_full_length(recs[p]), size=TEST_TRAJECTORIES[p], replace=False))
        test[p] = recs[p].select(sorted(held))
        if p != "planned-paths":
            pool.append(recs[p].select([t for t in recs[p].trajectories if t not in held]))
    budget = train_frames - sum(r.n_frames for r in pool)
    term = recs["terminal-only"]
    order = list(rng.permutation(term.trajectories))
    chosen, frames = [], 0
    for t in order:
        n = int(np.sum(term.trajectory_ids == t))
        if frames + n > budget:
            break
        chosen.append(t)
        frames += n
    pool.insert(0, term.select(sorted(chosen)))
    train, val = Recording.concat(pool).split((0.7, 0.3), seed=seed)
    return PaperSplit(train=train, val=val, test=test)


def score_test(model, test: dict) -> dict:
    """A fitted model's scores on the held-out protocols, and their frame-weighted overall (paper Table II).

    Parameters
    ----------
    model : TransmissionModel
    test : dict of str to Recording
        :attr:`PaperSplit.test`.

    Returns
    -------
    dict
        ``{"protocols": {protocol: model.score(...)}, "terminal": M, "joints": M | None}``; the
        overall ``joints`` needs intermediate truth in every protocol.
    """
    scores = {p: model.score(test[p]) for p in TEST_PROTOCOLS}
    frames = [test[p].n_frames for p in TEST_PROTOCOLS]
    joints = [scores[p]["joints"]["overall"] if scores[p]["joints"] else None for p in TEST_PROTOCOLS]
    return {
        "protocols": scores,
        "terminal": frame_weighted([scores[p]["terminal"] for p in TEST_PROTOCOLS], frames),
        "joints": frame_weighted(joints, frames) if all(joints) else None,
    }
