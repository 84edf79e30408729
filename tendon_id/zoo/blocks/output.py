"""Blocks on what leaves a guide and what the terminal load cell reads."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from friction_models import viscoelastic_lag
from tendon_id.zoo.blocks.base import Block


@dataclass(frozen=True)
class ViscoelasticLag(Block):
    """Zener lag of the tension leaving each guide (:doc:`/guide/simulator` ``viscoelastic``).

    Parameters
    ----------
    tau_v : float
        Relaxation time [s].
    kappa : float
        Relaxing fraction per guide; the default 0 starts a fit from "no lag", so a
        model with this block starts from its base model's fit.
    """

    name = "viscoelastic"
    effect = "viscoelastic"
    stage = "guide_output"
    regressor = "lagged minus instantaneous tension: residual follows the rate of tension change"
    tau_v: float = 1.0
    kappa: float = 0.0
    param_names: tuple[str, ...] = ("tau_v", "kappa")
    bounds: dict = field(default_factory=lambda: {"tau_v": (0.05, 60.0), "kappa": (0.0, 0.5)})
    probe: dict = field(default_factory=lambda: {"tau_v": (1.0, 5.0), "kappa": 0.04}, compare=False, repr=False)

    def probes(self) -> list[tuple[str, dict[str, float]]]:
        # kappa = 0 switches the lag off whatever tau_v, so each column is a lag of one time scale.
        return [(f"viscoelastic:tau={t:g}s", {"tau_v": t, "kappa": self.probe["kappa"]}) for t in self.probe["tau_v"]]

    def guide_output(self, y: NDArray, ctx, values: dict) -> NDArray:
        inputs = ctx.inputs
        return np.log(viscoelastic_lag(np.exp(y), inputs.dt, values["tau_v"], values["kappa"], inputs.reset))


@dataclass(frozen=True)
class SensorBias(Block):
    """Terminal load-cell bias ``(1 + gain) T + offset + drift * clock`` (:doc:`/guide/simulator` ``sensor_bias``).

    Parameters
    ----------
    offset : float
        [N].
    gain : float
        Relative gain error [-].
    drift : float
        [N/s] over the session clock.
    """

    name = "sensor_bias"
    effect = "sensor_bias"
    stage = "sensor"
    regressor = "a constant, the tension and the session clock"
    offset: float = 0.0
    gain: float = 0.0
    drift: float = 0.0
    param_names: tuple[str, ...] = ("offset", "gain", "drift")
    bounds: dict = field(default_factory=lambda: {"offset": (-50.0, 50.0), "gain": (-0.3, 0.3), "drift": (-0.1, 0.1)})
    probe: dict = field(default_factory=lambda: {"offset": 1.0, "gain": 0.01, "drift": 1e-3}, compare=False, repr=False)

    def sensor(self, tension: NDArray, ctx, values: dict) -> NDArray:
        return (1.0 + values["gain"]) * tension + values["offset"] + values["drift"] * ctx.inputs.clock[:, None]
