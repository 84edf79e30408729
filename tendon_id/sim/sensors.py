"""Load cells and encoders: noise, range and quantisation (:doc:`/guide/simulator`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tendon_id.errors import ConfigError
from tendon_id.sim.sensor_effects import SensorBias


@dataclass(frozen=True)
class Sensors:
    """Measurement chain, always on.

    Parameters
    ----------
    noise_n : float
        Load-cell noise standard deviation [N]. Default 1.0.
    range_n : float
        Load-cell full scale [N]; readings saturate there (paper: 500 N).
    encoder_bits : int
        Resolution of the magnetic joint encoders (paper: 12-bit).
    """

    noise_n: float = 1.0
    range_n: float = 500.0
    encoder_bits: int = 12

    def __post_init__(self) -> None:
        if self.noise_n < 0 or self.range_n <= 0 or not 4 <= self.encoder_bits <= 24:
            raise ConfigError("sensors need noise_n >= 0, range_n > 0 and 4 <= encoder_bits <= 24")

    @property
    def angle_step(self) -> float:
        """Encoder quantum [rad]."""
        return 2.0 * np.pi / 2**self.encoder_bits

    def read_angles(self, theta: NDArray) -> NDArray:
        """Quantised encoder readings [rad] of true angles."""
        q = self.angle_step
        return np.round(theta / q) * q

    def read_tensions(self, rng: np.random.Generator, tension: NDArray) -> NDArray:
        """Noisy, saturating load-cell readings [N]; never below 1e-3 N (a load cell reads no compression)."""
        noisy = tension + self.noise_n * rng.standard_normal(tension.shape)
        return np.clip(noisy, 1e-3, self.range_n)


def apply_sensor_bias(tension: NDArray, clock_s: NDArray, bias: SensorBias) -> NDArray:
    """Terminal load-cell bias: ``(1 + gain) T + offset + drift * clock`` [N] (or its warm-up form).

    Parameters
    ----------
    tension : ndarray, shape (T, 3)
    clock_s : ndarray, shape (T,)
        Session clock [s] (runs on across trajectories).
    """
    clock = np.asarray(clock_s, dtype=float)
    if bias.drift_form == "warm_up":  # the same initial rate, settling over warm_up_s
        clock = -bias.warm_up_s * np.expm1(-clock / bias.warm_up_s)
    return (1.0 + bias.gain) * tension + bias.offset + bias.drift * clock[:, None]
