"""The elastic tendon chain on the composed route: the reference of the compiled pass (:doc:`/guide/simulator`).

With ``stick_slip.driver = "elastic"`` every tendon is an elastic chain through its guides
(:mod:`friction_models.elastic_chain`): its segments stretch with their tension, their path
lengths follow the joints through the exact hole-point geometry, and each guide holds a
capstan band.  The compiled pass (:mod:`tendon_id.sim.transmission_kernel`) runs the same
solver, compiled; this module runs it as written, one tendon at a time, for the tests.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from friction_models import SLACK_FLOOR_N
from friction_models.elastic_chain import elastic_chain
from tendon_id.geometry import RobotGeometry
from tendon_id.sim.effects import Effects
from tendon_id.sim.transmission_kernel import COMPILED, elastic_chain_frame
from tendon_id.sliding import segment_length, segment_path_lengths

try:  # pragma: no cover - which branch runs depends on the install
    import numba
except ImportError:  # pragma: no cover
    numba = None

__all__ = ["ElasticState", "transmit_elastic"]


def transmit_elastic(theta, actuator, reset, geometry: RobotGeometry, effects: Effects, dt, phi, loss):
    """The elastic chains of every set and tendon, on the composed route (the reference; loops in Python).

    Parameters
    ----------
    theta, actuator, reset, geometry, effects, dt :
        As for :func:`~tendon_id.sim.transmission.transmit`.
    phi, loss : ndarray, shape (T, N-1, N, n)
        Capstan exponent [-] and tension-independent loss [N] of every guide, set and tendon
        (the exponent-stage blocks, :func:`~tendon_id.sim.transmission.guide_terms`).

    Returns
    -------
    chain : ndarray, shape (T, N, N, n)
        ``T[k, j, i]`` [N], NaN off the path.
    sigma : ndarray of int8, shape (T, N-1, N, n)
    """
    n, n_frames = geometry.n_modules, theta.shape[0]
    reset = np.array(reset, dtype=bool)
    reset[0] = True
    visco = effects.get("viscoelastic") if "viscoelastic" in effects else None
    length = segment_path_lengths(theta, geometry)
    d_length = np.zeros_like(length)
    d_length[1:] = length[1:] - length[:-1]
    d_length[reset] = 0.0
    k = np.full(n - 1, float(effects.get("stick_slip").EA) / segment_length(geometry))
    nt = actuator.shape[2]  # tendons per set
    chain = np.full((n_frames, n, n, nt), np.nan)
    sigma = np.zeros((n_frames, n - 1, n, nt), dtype=np.int8)
    chain[:, 0] = actuator
    for j in range(1, n):
        for i in range(nt):
            tension, sg = elastic_chain(
                actuator[:, j, i],
                d_length[:, :j, j, i],
                phi[:, :j, j, i],
                k[:j],
                reset,
                loss=loss[:, :j, j, i],
                dt=dt,
                tau=visco.tau_v if visco is not None else 1.0,
                kappa=visco.kappa if visco is not None else 0.0,
                floor=SLACK_FLOOR_N,
            )
            chain[:, 1 : j + 1, j, i] = tension
            sigma[:, :j, j, i] = sg
    return chain, sigma


def _step(actuator, phi, loss, d_length, tension, branch, first, k_seg, a_lag, kappa, floor, sigma):  # pragma: no cover
    # One instant of every chain of a batch (the closed loop's plant): the compiled pass's elastic
    # branch without its frame loop.  tension/branch/sigma: (B, N-1, N, n) state, updated in place.
    batch, n, nt = actuator.shape[0], actuator.shape[1], actuator.shape[2]
    scratch = np.empty((5, n - 1))
    c, k, cp, em, ep = scratch[0], scratch[1], scratch[2], scratch[3], scratch[4]
    k[:] = k_seg
    for b in range(batch):
        for j in range(1, n):
            for i in range(nt):
                elastic_chain_frame(
                    actuator[b, j, i], tension[b, :j, j, i], branch[b, :j, j, i], d_length[b, :j, j, i],
                    phi[b, :j, j, i], loss[b, :j, j, i], k[:j], first, a_lag, kappa, floor,
                    c[:j], cp[:j], em[:j], ep[:j], sigma[b, :j, j, i],
                )  # fmt: skip


if COMPILED:
    _step = numba.njit(cache=True, nogil=True)(_step)


class ElasticState:
    """The elastic chains of a batch of robots, stepped one instant at a time (the closed loop's plant).

    Parameters
    ----------
    geometry, effects :
        The robot and the recipe's effects (``stick_slip.driver = "elastic"``).
    dt : float
        Time between steps [s] (the viscoelastic tendon's step).
    batch : int
        Number of robots.
    """

    def __init__(self, geometry: RobotGeometry, effects: Effects, dt: float, batch: int):
        n = geometry.n_modules
        visco = effects.get("viscoelastic") if "viscoelastic" in effects else None
        self.geometry = geometry
        self.k_seg = float(effects.get("stick_slip").EA) / segment_length(geometry)
        self.a_lag = math.exp(-dt / visco.tau_v) if visco is not None else 1.0
        self.kappa = float(visco.kappa) if visco is not None else 0.0
        nt = geometry.n_tendons
        self.tension = np.zeros((batch, n - 1, n, nt))
        self.branch = np.zeros((batch, n - 1, n, nt))
        self.sigma = np.zeros((batch, n - 1, n, nt), dtype=np.int8)
        self.length = None

    def step(self, theta: NDArray, actuator: NDArray, phi: NDArray, loss: NDArray | None) -> NDArray:
        """Advance one instant; returns the segment tensions ``T[k+1, j, i]`` (B, N-1, N, n) [N] (0 off the path)."""
        length = segment_path_lengths(theta, self.geometry)
        first = self.length is None
        d_length = np.zeros_like(length) if first else length - self.length
        self.length = length
        loss = np.zeros(phi.shape) if loss is None else np.ascontiguousarray(np.broadcast_to(loss, phi.shape))
        _step(
            np.ascontiguousarray(actuator, dtype=float),
            np.ascontiguousarray(phi, dtype=float),
            loss,
            d_length,
            self.tension,
            self.branch,
            first,
            self.k_seg,
            self.a_lag,
            self.kappa,
            float(SLACK_FLOOR_N),
            self.sigma,
        )
        return self.tension
