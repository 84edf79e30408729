"""Streaming PG-CHTC, one frame at a time (paper Algorithm 1; :doc:`/guide/pgchtc`)."""

from __future__ import annotations

import warnings

import numpy as np
import torch

from learners.cascade import StreamingCascade
from learners.streaming_native import KernelUnavailable, NativeStreamingCascade
from learners.streaming_native import disabled as native_disabled
from learners.streaming_pack import WEIGHT_FORMATS
from tendon_id.checks import check_choice
from tendon_id.errors import ConfigError, TendonIdError
from tendon_id.zoo.features import unit_inputs

__all__ = ["STREAM_ENGINES", "PGCHTCStream"]

#: The streaming engines: the compiled kernel, the traced torch graph, or whichever runs here.
STREAM_ENGINES = ("auto", "native", "torch")


class PGCHTCStream:
    """Streaming PG-CHTC: ``step(frame) -> (N, n)`` joint-side estimates [N] (paper Algorithm 1), ``n`` tendons per set.

    Parameters
    ----------
    model : tendon_id.zoo.learned.PGCHTC
        A fitted model (its ``cascade_``, ``n_modules_`` and ``alpha_0_`` are read).
    engine : {"auto", "native", "torch"}
        ``"native"`` runs each frame in a small C kernel compiled once per machine
        (:mod:`learners.streaming_native`); ``"torch"`` in a traced TorchScript graph
        (:class:`~learners.cascade.StreamingCascade`).  Both compute the same frame as batch
        inference: units in float32, inputs and chain in float64.  ``"auto"`` (default) takes
        the kernel where it builds and the model is a float32 CPU model, and the torch engine
        otherwise (with a warning if the kernel failed to build).
    threads : {1, 2, "auto"}, optional
        Native engine only: 2 computes ``g_phi`` on a helper thread beside ``f_theta`` within
        each frame, with the same result to the bit; ``"auto"`` runs each frame on the count
        that has been faster lately (a helper pays only where a second core is free).  Default:
        ``"auto"`` where the units are large enough for a helper to pay and the process may use
        two CPUs, else 1.
    weights : {"float32", "float16"}
        Native engine only: the precision its matrix products read the weights in.
        ``"float32"`` (default) is the reference; ``"float16"`` halves the weights' memory
        traffic, at the agreement the latency benchmark measures
        (:class:`~learners.streaming_native.NativeStreamingCascade`).  It selects the native
        engine under ``engine="auto"``.

    Attributes
    ----------
    engine_name : str
        The engine in use, ``"native"`` or ``"torch"``.
    """

    def __init__(self, model, engine: str = "auto", threads: int | str | None = None, weights: str = "float32"):
        if engine not in STREAM_ENGINES:
            check_choice("engine", engine, STREAM_ENGINES, what="streaming engine")
        if threads not in (None, 1, 2, "auto"):
            raise ConfigError(f"threads must be 1, 2 or 'auto'; got {threads!r}")
        if weights not in WEIGHT_FORMATS:
            check_choice("weights", weights, WEIGHT_FORMATS, what="weight format")
        if weights != "float32":
            if engine == "torch":
                raise ConfigError(f"weights={weights!r} needs the native engine; the torch engine computes in float32")
            engine = "native"
        self.model = model
        self.alpha0 = model.alpha_0_  # the prior's fitted routing wrap, never the robot's metadata
        self.engine_name = "torch"
        if engine in ("auto", "native"):
            try:
                self.engine = NativeStreamingCascade(model.cascade_, model.n_modules_, threads, weights)
                self.engine_name = "native"
            except ValueError as exc:  # weights beyond float16's range
                raise ConfigError(str(exc)) from None
            except KernelUnavailable as exc:
                if engine == "native":
                    raise TendonIdError(f"the native streaming engine is unavailable: {exc}") from None
                if not native_disabled():  # switched off on purpose: no warning
                    warnings.warn(f"streaming on the slower torch engine: {exc}", RuntimeWarning, stacklevel=3)
        if self.engine_name == "torch":
            self.engine = StreamingCascade(model.cascade_, model.n_modules_)

    def reset(self) -> None:
        """Start a new trajectory."""
        self.engine.reset()

    def close(self) -> None:
        """End the native engine's helper thread now, not when the streamer is collected (a later step
        starts another).  Nothing to do for the torch engine."""
        if self.engine_name == "native":
            self.engine.close()

    def step(self, angles: np.ndarray, actuator: np.ndarray) -> np.ndarray:
        """One frame: joint angles (N, 2) [rad] and actuator-side tensions (N, n) [N] in; ``T_hat[j, j]`` (N, n) out."""
        frame = unit_inputs(angles, actuator, self.alpha0)
        out = self.engine.step(*frame) if self.engine_name == "native" else self._torch_step(*frame)
        est = np.exp(out)
        est[0] = actuator[0]
        return est

    def _torch_step(self, sin_q: np.ndarray, alpha: np.ndarray, log_act: np.ndarray) -> np.ndarray:
        """The torch engine on one thread: a frame is hundreds of small operations, for which waking a
        second OpenMP thread costs more than it saves (measured for the paper preset on 2 cores: 5.0
        against 5.0 ms traced, 7.2 against 7.1 ms eager; one thread keeps other work free)."""
        threads = torch.get_num_threads()
        if threads != 1:
            torch.set_num_threads(1)
        try:
            return self.engine.step(*map(torch.as_tensor, (sin_q, alpha, log_act))).numpy()
        finally:
            if threads != 1:
                torch.set_num_threads(threads)
