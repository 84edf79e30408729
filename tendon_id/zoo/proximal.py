"""The proximal hypothesis: no transmission loss (the paper's "Proximal measurement" row)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from tendon_id.data import Recording
from tendon_id.zoo.base import TransmissionModel
from tendon_id.zoo.inputs import as_recordings


class ProximalModel(TransmissionModel):
    """No loss: every joint side equals its actuator side (the paper's "Proximal measurement").

    Parameters
    ----------
    robot : dict, optional
        Unused; accepted so that every zoo model takes it.
    """

    name = "proximal"

    def __init__(self, robot: dict | None = None):
        self.robot = robot

    def fit(self, data: Recording | Sequence[Recording]) -> ProximalModel:
        recs = [r.fitting_view() for r in as_recordings(data)]
        self.n_modules_ = recs[0].n_modules
        return self

    def predict_chain(self, data: Recording | Sequence[Recording]) -> NDArray[np.float64]:
        recs = self._check_data(data)
        act = np.concatenate([r.actuator for r in recs])  # (T, N, n)
        n = act.shape[1]
        chain = np.broadcast_to(act[:, None], (act.shape[0], n, n, act.shape[2])).copy()
        chain[:, np.arange(n)[:, None] > np.arange(n)[None, :]] = np.nan  # k > j is off the path
        return chain

    def _state(self):
        return {"n_modules": self.n_modules_}, {}

    def _restore(self, state, arrays):
        self.n_modules_ = int(state["n_modules"])
