"""The snake chain's part of :func:`~tendon_id.zoo.testing.check_model`: shapes, hidden truth, another robot size.

A snake model predicts every joint side (T, N, n) and the whole chain (T, N, N, n) for n tendons per set; it fits on
the terminal label alone, so scrambled intermediate truth changes nothing it predicts; and it
refuses a robot of another size.
"""

from __future__ import annotations

import numpy as np

from tendon_id.data import Recording
from tendon_id.zoo.testing import same_bits

__all__ = ["check_shapes", "check_terminal_only", "scrambled_truth", "shorter_robot"]

#: Robot metadata that ties a recording to its module count.
SIZE_KEYS = ("n_modules", "robot")


def check_shapes(model, test: Recording) -> np.ndarray:
    """Shapes of ``predict`` (T, N, n) and ``predict_chain`` (T, N, N, n), NaN exactly where ``k > j``.

    Returns ``predict``.
    """
    t, n, m = test.n_frames, test.n_modules, test.n_tendons
    pred, chain = model.predict(test), model.predict_chain(test)
    assert pred.shape == (t, n, m), f"{model.name}: predict shape {pred.shape}, expected {(t, n, m)}"
    assert chain.shape == (t, n, n, m), f"{model.name}: predict_chain shape {chain.shape}, expected {(t, n, n, m)}"
    below = np.arange(n)[:, None] > np.arange(n)[None, :]
    assert np.isnan(chain[:, below]).all(), f"{model.name}: predict_chain must be NaN where k > j"
    assert np.isfinite(chain[:, ~below]).all(), f"{model.name}: predict_chain must be finite where k <= j"
    diagonal = chain[:, np.arange(n), np.arange(n)]
    assert np.array_equal(diagonal, pred), f"{model.name}: predict must be predict_chain's diagonal T[j, j]"
    return pred


def check_terminal_only(model, train: Recording, test: Recording, pred: np.ndarray, seed: int) -> None:
    """A fresh copy of ``model`` fitted on ``train`` with scrambled intermediate truth predicts ``pred`` to the bit."""
    other = type(model)(**model.get_params()).fit(scrambled_truth(train, seed))
    assert same_bits(other.predict(test), pred), (
        f"{model.name}: scrambling the intermediate joint-side truth of the training data changed the predictions; "
        "a model must fit on terminal labels only"
    )


def scrambled_truth(rec: Recording, seed: int) -> Recording:
    """``rec`` with random intermediate joint-side truth [N] (kept or added), the terminal label unchanged.

    A model fitted on it must predict exactly what it predicts when fitted on ``rec``.
    """
    rng = np.random.default_rng(seed)
    n = rec.n_modules
    truth = rng.uniform(1.0, 400.0, size=(rec.n_frames, n, rec.n_tendons))
    truth[:, -1] = rec.terminal
    return Recording.from_arrays(
        trajectory=rec.trajectory_ids,
        t=rec.time,
        angles=rec.angles,
        actuator=rec.actuator,
        terminal=rec.terminal,
        joint_truth=truth,
        meta=rec.meta,
    )


def shorter_robot(rec: Recording) -> Recording:
    """A valid recording of a robot one module shorter (the last module's tensions as terminal)."""
    meta = {k: v for k, v in rec.meta.items() if k not in SIZE_KEYS}
    return Recording.from_arrays(
        trajectory=rec.trajectory_ids,
        t=rec.time,
        angles=rec.angles[:, :-1],
        actuator=rec.actuator[:, :-1],
        terminal=rec.actuator[:, -2],
        meta=meta,
    )
