"""The passage's effect blocks: what the capstan passage leaves out, one block per effect (:doc:`/guide/data`).

A passage model predicts one side from the other through two slip edges, the forward-slip and
the reverse-slip value of the predicted side (:mod:`friction_models.passage`). Blocks act at one
of three stages:

=========  ===============================================  =======================================
stage      hook                                              blocks
=========  ===============================================  =======================================
``load``   ``load(inputs, values) -> (T,)``: a torque or     ``position_torque``, ``velocity_friction``,
           tension added on the output side [N m or N]       ``load_coulomb``
``state``  where the predicted side sits between its edges   ``stick_slip`` (held through reversals)
``edge``   how it moves from one edge to the other           ``smooth_edge`` (Maxwell slip)
=========  ===============================================  =======================================

Without a ``state`` block the passage has no memory: the predicted side is on the edge of the
current slip state, the paper's Eq. (6) with ``sigma`` = +1 or -1 while the input moves and 0 in
stick (at rest, the ratio is 1). ``stick_slip`` holds it through rests and reversals instead.
Without an ``edge`` block the switch is sharp.
Effects keep the snake's names where the physics is the same (``stick_slip``,
``velocity_friction``). Each block declares its parameters with bounds, the neutral value that
switches it off, and a probe (a typical magnitude) for the diagnosis's signatures.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from tendon_id.errors import ConfigError
from tendon_id.family.blocks import BlockRegistry, EffectBlock

PASSAGE_STAGES = ("load", "state", "edge")
#: The bench passage's blocks, filled as each block class is defined.
BLOCKS = BlockRegistry("passage")
#: Every passage block class by effect name (a passage block's name is its effect's).
PASSAGE_BLOCKS: dict[str, type[PassageBlock]] = BLOCKS.by_effect


@dataclass(frozen=True)
class PassageBlock(EffectBlock):
    """Base of the passage blocks (the declarations are :class:`~tendon_id.family.blocks.EffectBlock`'s).

    Class attributes besides: ``units`` (per parameter, with ``Q`` for the passage's quantity:
    N or N m). Bounds, starts and probes depend on the data's scales (``scale``: ``signal``
    [Q], ``input`` [Q], ``travel``, ``angle`` [rad], ``speed`` [rad/s]).
    """

    registry: ClassVar[BlockRegistry] = BLOCKS
    stages: ClassVar[tuple[str, ...]] = PASSAGE_STAGES
    stage: ClassVar[str] = "load"
    param_names: ClassVar[tuple[str, ...]] = ()
    units: ClassVar[dict[str, str]] = {}

    def to_dict(self) -> dict:
        """What the diagnosis reports of the block: its effect."""
        return {"effect": self.effect}

    def initial(self, scale: dict) -> dict[str, float]:
        """Where a fit starts the parameters (default: neutral)."""
        return self.neutral()

    def bounds(self, scale: dict) -> dict[str, tuple[float, float]]:
        """``(lower, upper)`` per parameter, from the data's scales (``signal`` [Q], ``travel``, ``speed``)."""
        return {}

    def probe(self, scale: dict) -> dict[str, float]:
        """A typical magnitude per parameter (the diagnosis's signature step)."""
        return {}

    def check(self, inputs) -> None:
        """Raise ConfigError where the data lacks a signal the block reads."""
        for need in self.missing(inputs):
            raise ConfigError(f"the {self.effect} block needs the {need.replace('_', '-')} column in the data")

    def load(self, inputs, values: dict) -> NDArray:  # pragma: no cover - the load blocks override it
        raise NotImplementedError


@dataclass(frozen=True)
class StickSlip(PassageBlock):
    """Stick/slip: the predicted side holds through a reversal until the other side crosses the band.

    The play operator on the two slip edges (Krasnosel'skii & Pokrovskii 1989), the paper's
    nonsmooth capstan in one passage: while the driving side's signal stays between the edges,
    the cable sticks and the predicted side keeps its value. The band is the capstan's own, so
    it grows with load where one cable of a pair goes slack or the pair shares the load. No
    free parameter.
    """

    name: ClassVar[str] = "stick_slip"
    effect: ClassVar[str] = "stick_slip"
    stage: ClassVar[str] = "state"
    regressor: ClassVar[str] = "a residual that holds after each reversal (hysteresis)"


@dataclass(frozen=True)
class SmoothEdge(PassageBlock):
    """A smooth edge of the stick/slip band: slip spreads along the wrap (generalised Maxwell slip).

    The band's play operator becomes the mean of play operators whose half-widths spread over
    ``(1 +- width)`` of the band's (:func:`friction_models.maxwell_slip.maxwell_slip_output`;
    Al-Bender, Lampaert & Swevers 2005): after a reversal the predicted side holds until the
    driving side has crossed about ``1 - width`` of the band, joins the new edge gradually, and
    slides on it beyond ``1 + width``, as a compliant cable's slip zone grows along its contact.
    ``width`` is a fraction of the band [-], 0 the sharp edge. It refines ``stick_slip`` and
    needs it. (A Dahl lag in the input's travel fitted to zero on ``Tool_4_Maryland_L_2``,
    where this form lowers the error: the bench's edge is spread in the band, not in travel.)
    """

    name: ClassVar[str] = "smooth_edge"
    effect: ClassVar[str] = "smooth_edge"
    stage: ClassVar[str] = "edge"
    param_names: ClassVar[tuple[str, ...]] = ("width",)
    units: ClassVar[dict[str, str]] = {"width": "-"}
    regressor: ClassVar[str] = "a residual of opposite signs just before and after each reversal"
    requires: ClassVar[tuple[str, ...]] = ("stick_slip",)

    def bounds(self, scale):
        return {"width": (0.0, 1.0)}

    def probe(self, scale):
        return {"width": 0.2}

    def initial(self, scale):
        # The loss is flat at width 0 (every element then is the same play operator): start inside.
        return self.probe(scale)


@dataclass(frozen=True)
class PositionTorque(PassageBlock):
    """A torque (or tension) that depends on position: ``k1 x + k2 x^2`` on the output side.

    ``x`` is the output position where the data has it, else the input position [rad]; springs,
    wiring and a wrap that changes with the angle act so. ``k1`` [Q/rad], ``k2`` [Q/rad^2].
    """

    name: ClassVar[str] = "position_torque"
    effect: ClassVar[str] = "position_torque"
    param_names: ClassVar[tuple[str, ...]] = ("k1", "k2")
    units: ClassVar[dict[str, str]] = {"k1": "Q/rad", "k2": "Q/rad^2"}
    regressor: ClassVar[str] = "the position (and its square)"
    needs: ClassVar[tuple[str, ...]] = ("position",)

    @staticmethod
    def angle(inputs) -> NDArray:
        return inputs.position_out if inputs.position_out is not None else inputs.position

    def bounds(self, scale):
        b = 10.0 * scale["signal"] / max(scale["angle"], 1e-9)
        return {"k1": (-b, b), "k2": (-b / max(scale["angle"], 1e-9), b / max(scale["angle"], 1e-9))}

    def probe(self, scale):
        return {
            "k1": 0.1 * scale["signal"] / max(scale["angle"], 1e-9),
            "k2": 0.1 * scale["signal"] / scale["angle"] ** 2,
        }

    def load(self, inputs, values):
        x = self.angle(inputs)
        return values["k1"] * x + values["k2"] * x**2


@dataclass(frozen=True)
class VelocityFriction(PassageBlock):
    """Viscous friction: ``-c v`` on the output side, ``v`` the input speed [rad/s]; ``c`` [Q s/rad], >= 0.

    The same effect as the snake's ``velocity_friction``: a friction that grows with speed.
    """

    name: ClassVar[str] = "velocity_friction"
    effect: ClassVar[str] = "velocity_friction"
    param_names: ClassVar[tuple[str, ...]] = ("c",)
    units: ClassVar[dict[str, str]] = {"c": "Q s/rad"}
    regressor: ClassVar[str] = "the input speed"

    def bounds(self, scale):
        # Viscous friction dissipates: c >= 0.
        return {"c": (0.0, 10.0 * scale["signal"] / max(scale["speed"], 1e-9))}

    def probe(self, scale):
        return {"c": 0.1 * scale["signal"] / max(scale["speed"], 1e-9)}

    def load(self, inputs, values):
        return -values["c"] * inputs.speed()


@dataclass(frozen=True)
class LoadCoulomb(PassageBlock):
    """Coulomb friction on the load side: ``-f sigma`` on the output, ``sigma`` the slip state; ``f`` [Q].

    Friction between the cables and the output sensor (a joint's pivot), outside the capstan:
    it does not scale with the cable tensions, flips with the motion and is 0 in stick
    (:meth:`~tendon_id.zoo.passage.inputs.PassageInputs.slip_state`), so it does not hold
    through a reversal. It opposes the motion, so ``f >= 0``.
    """

    name: ClassVar[str] = "load_coulomb"
    effect: ClassVar[str] = "load_coulomb"
    param_names: ClassVar[tuple[str, ...]] = ("f",)
    units: ClassVar[dict[str, str]] = {"f": "Q"}
    regressor: ClassVar[str] = "the slip state (the sign of the motion, 0 at rest)"

    def bounds(self, scale):
        # Friction between the cables and the output sensor opposes the motion: f >= 0.
        return {"f": (0.0, scale["signal"])}

    def probe(self, scale):
        return {"f": 0.05 * scale["signal"]}

    def load(self, inputs, values):
        return -values["f"] * inputs.slip_state(scale_band(inputs))


def scale_band(inputs) -> float:
    """The deadband of the direction of motion: twice the median non-zero step of the travel."""

    def compute():
        step = np.abs(np.diff(inputs.travel()))
        step = step[step > 0]
        return 2.0 * float(np.median(step)) if step.size else 1e-12

    return inputs.memo("band", compute)


def make_block(effect: str | PassageBlock) -> PassageBlock:
    """The block of ``effect`` (ConfigError naming the known ones otherwise); a block is returned as it is."""
    return effect if isinstance(effect, PassageBlock) else BLOCKS[effect]()
