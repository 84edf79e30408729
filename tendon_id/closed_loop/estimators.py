"""Estimators in the loop: each maps one frame of measurements to the whole tension chain.

The controller needs every ``T[k, j, i]``, a set's tension at each joint it crosses, not only
at its own (:mod:`~tendon_id.closed_loop.controller`).  A fitted zoo model runs causally, one
frame at a time, by predicting its chain (``predict_chain``) on the whole history so far and
keeping the last frame.  Every zoo model's prediction is causal, so this is what it would
give online; the history route costs O(t) per frame, which a run of a few hundred frames
affords.  A model with a history window (``history_frames``, 20 for the cascades) sees the run's
first frame repeated before it: the plant starts at rest, at its pretension.  Where the plant
drives each joint by its own set only (``JointDynamics(statics="own_set")``) the controller
reads the chain's diagonal alone, and a model with a streaming engine (``pg-chtc``,
``pg-chtc-ns``, the capstan models whose blocks stream) runs through it, which gives each set's own joint only.
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

    def reset(self, needs_chain: bool = True) -> None:
        """Forget the last run; ``needs_chain`` False: only the chain's diagonal will be read."""

    def step(self, angles: NDArray, actuator: NDArray, truth: NDArray) -> NDArray:
        """Chain estimate ``T_hat[k, j, i]`` (N, N, n) [N] from angles (N, 2) [rad] and actuator side (N, n) [N].

        ``n`` is the robot's tendons per set.  ``truth`` is the measured true chain (N, N, n); only the
        oracle reads it.  Entries off the path (``k > j``) are not read.
        """
        raise NotImplementedError


class OracleInLoop(InLoopEstimator):
    """The true transmission: a load cell on every tendon at every joint it crosses."""

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
        self.streamer = getattr(model, "streamer", None)
        if getattr(model, "uses_prior_", False):
            self.streamer = None
        self._engine = None  # built once, on the first run that reads the diagonal alone
        self.reset()

    def reset(self, needs_chain: bool = True) -> None:
        self.stream = None
        if not needs_chain and self.streamer is not None and self._engine is None:
            try:
                self._engine = self.streamer()
            except ConfigError:  # a capstan model with a block that does not stream: the history route
                self.streamer = None
        elif not needs_chain and self._engine is not None:
            self._engine.reset()
        if not needs_chain and self._engine is not None:
            self.stream = self._engine
        self.angles: list[NDArray] = []
        self.actuator: list[NDArray] = []

    def step(self, angles: NDArray, actuator: NDArray, truth: NDArray) -> NDArray:
        if self.stream is not None:  # each set's own joint only: the rest of the chain is unknown (NaN)
            own = self.stream.step(angles, actuator)
            n = own.shape[0]
            chain = np.full((n, n, own.shape[1]), np.nan)
            chain[np.arange(n), np.arange(n)] = own
            return chain
        if not self.angles:
            # Before the run the robot rested at its first frame (the plant starts at rest, at its
            # pretension), so a model that needs a history window sees that frame repeated.
            self.angles.extend([angles] * (self.model.history_frames - 1))
            self.actuator.extend([actuator] * (self.model.history_frames - 1))
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
        return self.model.predict_chain(rec)[-1]


def in_loop(name: str, model=None, dt: float = 0.1) -> InLoopEstimator:
    """The estimator ``name`` for the loop: the oracle, or a fitted ``model``."""
    if name == ORACLE:
        return OracleInLoop()
    if model is None:
        raise ConfigError(f"estimator {name!r} needs a fitted model")
    return ModelInLoop(model, name, dt)
