"""Estimators in the loop: each maps one frame of measurements to joint-side tensions.

A fitted zoo model runs causally, one frame at a time: through its own streaming engine
where it has one (``pg-chtc``, ``pg-chtc-ns``), else by predicting on the whole history so
far and keeping the last frame.  Every zoo model's ``predict`` is causal, so the two agree;
the history route costs O(t) per frame, which a run of a few hundred frames affords.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tendon_id.data import Recording
from tendon_id.errors import ConfigError

__all__ = ["ORACLE", "InLoopEstimator", "ModelInLoop", "OracleInLoop", "in_loop"]

#: Name of the estimator that reads the true joint side (a load cell at every joint).
ORACLE = "oracle"


class InLoopEstimator:
    """Frame-by-frame joint-side estimates; :meth:`reset` before each run."""

    name = "estimator"

    def reset(self) -> None:
        """Forget the last run."""

    def step(self, angles: NDArray, actuator: NDArray, truth: NDArray) -> NDArray:
        """Joint-side estimate (N, 3) [N] from measured angles (N, 2) [rad] and actuator side (N, 3) [N].

        ``truth`` is the measured true joint side; only the oracle reads it.
        """
        raise NotImplementedError


class OracleInLoop(InLoopEstimator):
    """The true transmission: joint-side load cells at every joint (the paper's robot has one)."""

    name = ORACLE

    def step(self, angles: NDArray, actuator: NDArray, truth: NDArray) -> NDArray:
        return truth


class ModelInLoop(InLoopEstimator):
    """A fitted zoo model, run causally.

    Parameters
    ----------
    model : TransmissionModel
        A fitted model with as many modules as the robot.
    name : str
        Its name in tables.
    dt : float
        Controller period [s] (the recording's sample period).
    """

    def __init__(self, model, name: str, dt: float):
        model.check_fitted()
        self.model, self.name, self.dt = model, name, float(dt)
        self.stream = None
        streamer = getattr(model, "streamer", None)
        if streamer is not None and not getattr(model, "uses_prior_", False):
            self.stream = streamer()
        self.reset()

    def reset(self) -> None:
        if self.stream is not None:
            self.stream.reset()
        self.angles: list[NDArray] = []
        self.actuator: list[NDArray] = []

    def step(self, angles: NDArray, actuator: NDArray, truth: NDArray) -> NDArray:
        if self.stream is not None:
            return self.stream.step(angles, actuator)
        self.angles.append(angles)
        self.actuator.append(actuator)
        n_frames = len(self.angles)
        act = np.asarray(self.actuator)
        rec = Recording.from_arrays(
            trajectory="closed-loop",
            t=np.arange(n_frames) * self.dt,
            angles=np.asarray(self.angles),
            actuator=act,
            terminal=act[:, -1],  # a placeholder label: predict never reads labels (docs/guide/data.rst)
            meta={"sample_rate_hz": 1.0 / self.dt},
        )
        return self.model.predict(rec)[-1]


def in_loop(name: str, model=None, dt: float = 0.1) -> InLoopEstimator:
    """The estimator ``name`` for the loop: the oracle, or a fitted ``model``."""
    if name == ORACLE:
        return OracleInLoop()
    if model is None:
        raise ConfigError(f"estimator {name!r} needs a fitted model")
    return ModelInLoop(model, name, dt)
