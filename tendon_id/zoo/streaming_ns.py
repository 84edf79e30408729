"""Streaming PG-CHTC-NS: one frame at a time, O(1) work and memory per frame.

The cascade's memory is its prior's play-operator state, so a frame needs nothing from the
past but that state: per guide, the play operator's output, the frames since it last moved
and the range its input has swept (:class:`friction_models.play_state.PlayStateStream`).
The correction's MLP runs in float64 numpy on the trained float32 weights; batch inference
runs it in float32 torch, and the two agree to far better than the 1e-5 relative :doc:`/guide/pgchtc`
asks (``tests/zoo/test_pgchtc_ns.py``).
"""

from __future__ import annotations

import numpy as np
from scipy.special import erf

from friction_models.play_state import PlayStateStream
from learners.cascade import LOG_RATIO_BOUND
from learners.unit import N_GEOMETRY
from tendon_id.zoo.features import unit_inputs
from tendon_id.zoo.inputs import TransmissionInputs


def _gelu(x: np.ndarray) -> np.ndarray:
    """The exact GELU of torch's default, ``x Phi(x)`` (Hendrycks & Gimpel 2016)."""
    return 0.5 * x * (1.0 + erf(x / np.sqrt(2.0)))


class PGCHTCNSStream:
    """``step(angles, actuator) -> (N, n)`` joint-side estimates [N] of a fitted :class:`PGCHTCNS` (``n`` tendons).

    Parameters
    ----------
    model : PGCHTCNS
        A fitted model.  Without correction (or when it falls back to its prior) this streams
        the calibrated capstan-nonsmooth.
    """

    def __init__(self, model):
        self.model = model
        self.prior = model.prior_model_
        self.values = self.prior.block_params_
        self.geometry = model.geometry_
        self.n = model.n_modules_
        self.n_tendons = model.n_tendons_
        self.dt = float(model.dt_)
        cascade = None if model.uses_prior_ else model.cascade_
        self.layers = []
        if cascade is not None:
            self.mean = cascade.feature_mean.double().numpy()
            self.std = cascade.feature_std.double().numpy()
            self.state_inputs = cascade.cfg.state_inputs
            self.bound = cascade.cfg.bound
            for unit in cascade.units:
                lin = [m for m in unit.body if hasattr(m, "weight")] + [unit.head]
                self.layers.append(
                    [(m.weight.detach().double().numpy().T, m.bias.detach().double().numpy()) for m in lin]
                )
        self.tied = cascade is None or cascade.tied
        self.reset()

    def reset(self) -> None:
        """Start a new trajectory: every guide's play operator starts on its forward-slip edge."""
        self.streams = None

    def _delta(self, g: int, x: np.ndarray) -> np.ndarray:
        layers = self.layers[0 if self.tied else g]
        h = x
        for w, b in layers[:-1]:
            h = _gelu(h @ w + b)
        w, b = layers[-1]
        return self.bound * np.tanh(h @ w + b)

    def _phi(self, angles: np.ndarray, actuator: np.ndarray) -> np.ndarray:
        """The prior's capstan exponent of one frame, shape (K, N|1, n), through its own blocks."""
        one = TransmissionInputs(
            angles=angles[None],
            actuator=actuator[None],
            terminal=np.ones((1, self.n_tendons)),
            reset=np.array([self.streams is None]),
            clock=np.zeros(1),
            dt=self.dt,
            geometry=self.geometry,
        )
        return self.prior.exponent(one, self.prior.A_, self.prior.B_, self.values)[0]

    def step(self, angles: np.ndarray, actuator: np.ndarray) -> np.ndarray:
        """One frame: joint angles (N, 2) [rad] and actuator-side tensions (N, n) [N] in; ``T_hat[j, j]`` (N, n) out.

        The prior's chain does not depend on the correction, so it runs first, guide by guide
        (one clamp each); the play operators' state is then updated for every guide at once,
        and only the correction runs guide by guide over the corrected chain.
        """
        angles = np.asarray(angles, dtype=float)
        actuator = np.asarray(actuator, dtype=float)
        n, n_t = self.n, self.n_tendons
        if actuator.shape != (n, n_t):
            raise ValueError(f"expected actuator-side tensions ({n}, {n_t}), got {actuator.shape}")
        start = self.streams is None
        if start:
            self.streams = PlayStateStream((n - 1, n, n_t), self.dt)  # guides x sets x tendons
        sq, alpha, log_act = unit_inputs(angles, actuator, self.prior.alpha_0_)  # the prior's fitted routing wrap
        phi = np.broadcast_to(self._phi(angles, actuator), (n - 1, n, n_t))
        x_in, lo, hi = (np.empty((n - 1, n, n_t)) for _ in range(3))
        x = log_act  # the prior's own chain; sets that no longer pass a guide carry values nobody reads
        for g in range(n - 1):
            x_in[g], lo[g], hi[g] = x, x - phi[g], x + phi[g]
            x = lo[g] if start else np.minimum(np.maximum(self.streams.y[g], lo[g]), hi[g])
        y, state = self.streams.step(lo, hi)  # the same clamps, and every guide's state
        ratio = y - x_in  # ln r_prior per guide and set
        x_hat = log_act.copy()  # the corrected chain
        if self.layers:
            g5 = slice(0, N_GEOMETRY)
            geo = (np.concatenate([sq, np.cos(alpha)[:, None]], axis=1) - self.mean[g5]) / self.std[g5]
        for g in range(n - 1):
            active = slice(g + 1, n)
            r = ratio[g, active]
            if self.layers:
                t = x_hat[active]
                tension = (np.exp(t) - self.mean[N_GEOMETRY:]) / self.std[N_GEOMETRY:]
                parts = [np.broadcast_to(geo[g], (n - g - 1, N_GEOMETRY)), tension]
                if self.state_inputs:
                    parts.append(state[g, active].reshape(n - g - 1, -1))
                r = np.clip(r + self._delta(g, np.concatenate(parts, axis=1)), -LOG_RATIO_BOUND, LOG_RATIO_BOUND)
            x_hat[active] = x_hat[active] + r
        est = np.exp(x_hat)
        est[0] = actuator[0]
        return est
