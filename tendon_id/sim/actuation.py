"""Actuator-side tensions set by the low-level puller–follower controller."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tendon_id.errors import ConfigError
from tendon_id.geometry import RobotGeometry, own_bend, tendon_azimuths
from tendon_id.sim.motion import smooth_noise


@dataclass(frozen=True)
class Actuation:
    """Tension model of the low-level controller that keeps every tendon taut (:doc:`/guide/simulator`).

    ``T[1, j, i](t) = P (1 + v s_ji(t)) + g [b_j(psi_ji, t)]_+``: a per-trajectory
    pretension level ``P`` (from the protocol's ``pretension_n`` range), a slow
    relative variation ``s`` of RMS ``v``, and the puller's antagonistic share
    ``g`` times the commanded bend of joint ``j`` projected on the tendon's
    azimuth (tendons on the outside of the bend are followers and keep ``P``),
    saturated at the controller's tension limit.
    The paper's taut regime (§III-D: minimum 62 N, 5th percentile 77 N) is
    respected by the pretension ranges of the recipes.

    Parameters
    ----------
    gain_n_per_rad : float
        Antagonistic gain ``g`` [N/rad]. Default 600.
    variation : float
        RMS of the slow relative variation ``v`` [-]. Default 0.04.
    variation_period_s : tuple of float
        Range of periods of the slow variation [s]. Default (20, 90).
    max_tension_n : float
        The controller's tension limit [N]; commands saturate there, so a
        load cell of 500 N range never clips. Default 450.
    """

    gain_n_per_rad: float = 600.0
    variation: float = 0.04
    variation_period_s: tuple[float, float] = (20.0, 90.0)
    max_tension_n: float = 450.0

    def __post_init__(self) -> None:
        if self.gain_n_per_rad < 0 or not 0 <= self.variation < 0.25 or not self.max_tension_n > 0:
            raise ConfigError("actuation needs gain_n_per_rad >= 0, 0 <= variation < 0.25 and max_tension_n > 0")
        object.__setattr__(self, "variation_period_s", tuple(float(p) for p in self.variation_period_s))

    def tensions(
        self, rng: np.random.Generator, theta: NDArray, pretension: float, geometry: RobotGeometry, dt: float
    ) -> NDArray:
        """Actuator-side tensions [N] of one trajectory, shape (T, N, 3).

        Parameters
        ----------
        rng : numpy.random.Generator
            Source of the slow variation.
        theta : ndarray, shape (T, N, 2)
            Commanded joint angles [rad].
        pretension : float
            This trajectory's pretension level ``P`` [N].
        geometry : RobotGeometry
            Supplies the tendon azimuths.
        dt : float
            Sample period [s].
        """
        psi = tendon_azimuths(geometry)  # (N, 3)
        bend = own_bend(theta, psi)  # b_j(psi_ji)
        slow = smooth_noise(rng, theta.shape[0], psi.shape, self.variation_period_s, dt)
        command = pretension * (1.0 + self.variation * slow) + self.gain_n_per_rad * np.maximum(bend, 0.0)
        return np.minimum(command, self.max_tension_n)
