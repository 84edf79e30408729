"""The estimator contract shared by every transmission hypothesis (scikit-learn conventions).

* ``__init__`` only stores settings; ``get_params``/``set_params`` read them back.
* ``fit(data)`` returns ``self``; fitted state ends in ``_``.
* ``predict(data)`` returns joint-side estimates ``T[j, j, i]``, shape (T, N, n) [N] for ``n``
  tendons per set, without side effects; ``predict_chain`` every ``T[k, j, i]``, shape (T, N, N, n).
* ``save(dir)``: ``model.json`` plus ``arrays.npz`` (never pickle); :func:`tendon_id.zoo.load`
  reads it back.
"""

from __future__ import annotations

import abc
from collections.abc import Sequence
from typing import Any

import numpy as np

from tendon_id.data import Recording
from tendon_id.errors import ConfigError
from tendon_id.family.registry import family_named
from tendon_id.metrics import tendon_metrics
from tendon_id.zoo.estimator import FORMAT_VERSION, Estimator, NotFittedError
from tendon_id.zoo.inputs import as_recordings

__all__ = ["FORMAT_VERSION", "NotFittedError", "TransmissionModel"]


class TransmissionModel(Estimator):
    """Base class of the snake chain's models of the zoo (see the module docstring)."""

    family = family_named("snake")

    # ---- fitting and prediction (each model implements fit and predict_chain) ------------
    @abc.abstractmethod
    def fit(self, data: Recording | Sequence[Recording]) -> TransmissionModel:
        """Fit on terminal-only labels; returns ``self``."""

    @abc.abstractmethod
    def predict_chain(self, data: Recording | Sequence[Recording]) -> np.ndarray:
        """Every ``T[k, j, i]`` [N], shape (T, N, N, n), NaN where ``k > j``."""

    def predict(self, data: Recording | Sequence[Recording]) -> np.ndarray:
        """Joint-side estimates ``T[j, j, i]`` [N], shape (T, N, n)."""
        chain = self.predict_chain(data)
        n = chain.shape[1]
        return chain[:, np.arange(n), np.arange(n)]

    def predict_terminal(self, data: Recording | Sequence[Recording]) -> np.ndarray:
        """What the terminal load cell is predicted to read [N], shape (T, n)."""
        return self.predict(data)[:, -1]

    @property
    def history_frames(self) -> int:
        """Frames a recording needs before ``predict`` accepts it: the history window, 1 without one."""
        return 1

    @property
    def is_fitted(self) -> bool:
        return bool(getattr(self, "n_modules_", None))

    def _check_data(self, data) -> list[Recording]:
        recs = as_recordings(data)
        self.check_fitted()
        for r in recs:
            if r.n_modules != self.n_modules_:
                raise ConfigError(
                    f"the model was fitted on {self.n_modules_} modules but {r.source or 'the data'} has {r.n_modules}"
                )
            fitted = getattr(getattr(self, "geometry_", None), "n_tendons", r.n_tendons)
            if r.n_tendons != fitted:
                raise ConfigError(
                    f"the model was fitted on {fitted} tendons per set but {r.source or 'the data'} has {r.n_tendons}"
                )
        return recs

    def score(self, data: Recording | Sequence[Recording]) -> dict[str, Any]:
        """Metrics of :doc:`/guide/zoo`: ``{"terminal": M, "joints": {"overall": M, "per_joint": [M, ...]} | None}``.

        ``joints`` needs simulator truth: ``per_joint`` lists joints ``1..N`` and
        ``overall`` pools the intermediate joints ``2..N-1``.
        """
        recs = self._check_data(data)
        truth = [r.joint_truth for r in recs]
        terminal = np.concatenate([r.terminal for r in recs])
        out: dict[str, Any] = {"terminal": tendon_metrics(self.predict_terminal(recs), terminal), "joints": None}
        if all(t is not None for t in truth):
            joint_truth = np.concatenate(truth)
            pred = self.predict(recs)
            n, m = pred.shape[1], pred.shape[2]
            per_joint = [tendon_metrics(pred[:, j], joint_truth[:, j]) for j in range(n)]
            inner = slice(1, n - 1) if n > 2 else slice(0, 0)
            overall = (
                tendon_metrics(pred[:, inner].reshape(-1, m), joint_truth[:, inner].reshape(-1, m)) if n > 2 else None
            )
            out["joints"] = {"overall": overall, "per_joint": per_joint}
        return out
