"""Effect blocks: the pieces an analytic transmission model is composed of.

A model propagates ``ln T`` of each tendon through the guides, proximal to
distal.  Blocks act at one of four stages:

``exponent``
    change the capstan exponent ``phi[t, k, i]`` of every guide (contact gate, wear);
``propagate``
    replace the forward-slip step ``ln T_out = ln T_in - phi`` (hysteresis);
``guide_output``
    transform the tension leaving each guide (viscoelastic lag);
``sensor``
    transform the predicted terminal reading (load-cell bias).

A block's parameters (``param_names``) are calibrated with the friction law
unless the block is built with ``fixed=True``.  The sim-to-real diagnosis adds
blocks to a fitted model this way.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from friction_models import hard_contact_gate, viscoelastic_lag
from friction_models.play_operator import play_output
from tendon_id.errors import ConfigError

STAGES = ("exponent", "propagate", "guide_output", "sensor")


@dataclass(frozen=True)
class Block:
    """Base of the effect blocks (see the module docstring)."""

    name = "block"
    stage = "exponent"
    param_names: tuple[str, ...] = ()
    #: (lower, upper) bound per parameter, in its units.
    bounds: dict = field(default_factory=dict)
    fixed: bool = False

    def initial(self) -> dict[str, float]:
        """Starting values of the block's parameters."""
        return {p: float(getattr(self, p)) for p in self.param_names}

    def to_dict(self) -> dict:
        return {"block": self.name, "fixed": self.fixed, **self.initial()}


@dataclass(frozen=True)
class ContactGate(Block):
    """Contact gate ``beta_k = 1[alpha_k > alpha_c]`` with the robot's clearance angle (paper Eq. (6))."""

    name = "contact"
    stage = "exponent"

    def exponent(self, phi: NDArray, wrap: NDArray, inputs, values: dict) -> NDArray:
        return phi * hard_contact_gate(wrap, inputs.geometry.alpha_c)[..., None]


@dataclass(frozen=True)
class Hysteresis(Block):
    """Stick/slip of the nonsmooth capstan: the log-domain play operator (paper §III-B, ref. [12])."""

    name = "hysteresis"
    stage = "propagate"

    def propagate(self, log_in: NDArray, phi: NDArray, inputs) -> NDArray:
        return play_output(log_in - phi, log_in + phi, inputs.reset)


@dataclass(frozen=True)
class ViscoelasticLag(Block):
    """Zener lag of the tension leaving each guide (DESIGN §5 ``viscoelastic``).

    Parameters
    ----------
    tau_v : float
        Relaxation time [s].
    kappa : float
        Relaxing fraction per guide; the default 0 starts a fit from "no lag", so a
        model with this block starts from its base model's fit.
    """

    name = "viscoelastic"
    stage = "guide_output"
    tau_v: float = 1.0
    kappa: float = 0.0
    param_names: tuple[str, ...] = ("tau_v", "kappa")
    bounds: dict = field(default_factory=lambda: {"tau_v": (0.05, 60.0), "kappa": (0.0, 0.5)})

    def guide_output(self, log_y: NDArray, inputs, values: dict) -> NDArray:
        return np.log(viscoelastic_lag(np.exp(log_y), inputs.dt, values["tau_v"], values["kappa"], inputs.reset))


@dataclass(frozen=True)
class SensorBias(Block):
    """Terminal load-cell bias ``(1 + gain) T + offset + drift * clock`` (DESIGN §5 ``sensor_bias``).

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
    stage = "sensor"
    offset: float = 0.0
    gain: float = 0.0
    drift: float = 0.0
    param_names: tuple[str, ...] = ("offset", "gain", "drift")
    bounds: dict = field(default_factory=lambda: {"offset": (-50.0, 50.0), "gain": (-0.3, 0.3), "drift": (-0.1, 0.1)})

    def sensor(self, tension: NDArray, inputs, values: dict) -> NDArray:
        return (1.0 + values["gain"]) * tension + values["offset"] + values["drift"] * inputs.clock[:, None]


BLOCK_TYPES = {cls.name: cls for cls in (ContactGate, Hysteresis, ViscoelasticLag, SensorBias)}


def block_from_dict(d: dict) -> Block:
    """Rebuild a block from :meth:`Block.to_dict`."""
    d = dict(d)
    cls = BLOCK_TYPES[d.pop("block")]
    return cls(**d)


def as_block(b: Block | str | dict) -> Block:
    """A block from a block, its name (default settings) or :meth:`Block.to_dict`'s dict."""
    if isinstance(b, Block):
        return b
    if isinstance(b, str):
        if b not in BLOCK_TYPES:
            raise ConfigError(f"unknown block {b!r}; known blocks: {', '.join(BLOCK_TYPES)}")
        return BLOCK_TYPES[b]()
    if isinstance(b, dict):
        return block_from_dict(b)
    raise ConfigError(f"a block must be a Block, a block name or a dict, got {b!r}")
