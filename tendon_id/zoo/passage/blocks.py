"""The passage's effect blocks: what the capstan passage leaves out, one block per effect (:doc:`/guide/data`).

A passage model predicts one side from the other through two slip edges, the forward-slip and
the reverse-slip value of the predicted side (:mod:`friction_models.passage`). Blocks act at one
of five stages, in this order:

==========  ==============================================  =======================================
stage       hook                                            blocks
==========  ==============================================  =======================================
``input``   the input sensor's reading undone before the    ``input_cells``
            law (:meth:`PassageBlock.true_input`)
``load``    ``load(inputs, values) -> (T,)``: a torque or   ``position_torque``, ``velocity_friction``,
            tension added on the output side [N m or N]     ``load_coulomb``
``state``   where the predicted side sits between its       ``stick_slip`` (held through reversals,
            edges                                           driven by the input's force),
                                                            ``cable_elasticity`` (by its travel)
``edge``    how it moves from one edge to the other         ``smooth_edge`` (Maxwell slip)
``sensor``  the predicted side's reading                    ``clock_skew``
            (:meth:`PassageBlock.sensor`)
==========  ==============================================  =======================================

Without a ``state`` block the passage has no memory: the predicted side is on the edge of the
current slip state, the paper's Eq. (6) with ``sigma`` = +1 or -1 while the input moves and 0 in
stick (at rest, the ratio is 1). ``stick_slip`` holds it through rests and reversals instead;
``cable_elasticity`` lets it cross the band as the input travels. A model has one state block.
Without an ``edge`` block the switch is sharp. The ``input`` and ``sensor`` blocks are in
:mod:`tendon_id.zoo.passage.sensor_blocks`.
Effects keep the snake's names where the physics is the same (``stick_slip``,
``velocity_friction``, ``clock_skew``). Each block declares its parameters with bounds, the
neutral value that switches it off (the model without the block, bit for bit), and a probe (a
typical magnitude) for the diagnosis's signatures.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from friction_models.play_operator import play_output
from tendon_id.errors import ConfigError
from tendon_id.family.blocks import BlockRegistry, EffectBlock
from tendon_id.family.inputs import frame_slices

#: Where a block acts, in the order of the forward computation (the module docstring's table).
PASSAGE_STAGES = ("input", "load", "state", "edge", "sensor")
#: The bench passage's blocks, filled as each block class is defined.
BLOCKS = BlockRegistry("passage")
#: Every passage block class by effect name (a passage block's name is its effect's).
PASSAGE_BLOCKS: dict[str, type[PassageBlock]] = BLOCKS.by_effect


@dataclass(frozen=True)
class PassageBlock(EffectBlock):
    """Base of the passage blocks (the declarations are :class:`~tendon_id.family.blocks.EffectBlock`'s).

    Class attributes besides: ``units`` (per parameter, with ``Q`` for the passage's quantity:
    N or N m). Bounds, starts and probes depend on the data's scales (``scale``: ``signal``
    [Q], ``input`` [Q], ``travel``, ``angle`` [rad], ``speed`` [rad/s], ``dt`` [s]).
    """

    registry: ClassVar[BlockRegistry] = BLOCKS
    stages: ClassVar[tuple[str, ...]] = PASSAGE_STAGES
    stage: ClassVar[str] = "load"
    param_names: ClassVar[tuple[str, ...]] = ()
    units: ClassVar[dict[str, str]] = {}
    #: Whether the block reads each frame from that frame and the state carried to it, so that a
    #: model with it can be evaluated in windows of frames (a block that reads later frames cannot).
    streams: ClassVar[bool] = True

    def derive(self, inputs) -> None:
        """Compute, on the whole inputs, the derived arrays the block reads (before windows read them)."""

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

    def true_input(self, u: NDArray, values: dict) -> NDArray:  # pragma: no cover - the input blocks override it
        """An ``input`` block: the input side's true signal [Q] from its reading ``u`` [Q]."""
        raise NotImplementedError

    def input_reading(self, x: NDArray, values: dict) -> NDArray:  # pragma: no cover - the input blocks override it
        """An ``input`` block: the input sensor's reading [Q] of the true signal ``x`` [Q] (the inverse direction)."""
        raise NotImplementedError

    def sensor(self, inputs, y: NDArray, values: dict, direction: str) -> NDArray:  # pragma: no cover
        """A ``sensor`` block: the predicted side [Q] as its sensor reads it, from the model's ``y`` [Q]."""
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
class CableElasticity(PassageBlock):
    """An elastic cable between the input and the contact: the band is crossed as the input travels.

    The cable between the input (its sensor and encoder) and the capstan contact is a spring of
    compliance ``C`` [rad/Q] (the input's travel per unit of force it puts into the cable,
    referred to the predicted side); the contact holds the force in the cable within the
    band. The cable's force ``e`` is then an elasto-plastic element: it follows the travel ``x``
    at slope ``1 / C`` and is held within the band's half-width ``h`` [Q], a play operator on
    ``x / C`` (Krasnosel'skii & Pokrovskii 1989), one Maxwell-slip element whose spring is the
    cable (Al-Bender, Lampaert & Swevers 2005; the cable as the contact's compliance: Kaneko,
    Paetsch & Tolle 1992, Agrawal, Peine & Yao 2010)::

        z = play(x / C; h),   e = x / C - z in [-h, h],   y = c + (e / h) (f - c)

    with ``f`` the edge of forward slip and ``c`` the band's centre: after a reversal the
    predicted side crosses the band linearly in the travel, over ``2 h C`` [rad], and rests hold
    it (the stretch keeps its force). A log starts on the edge of its first motion.

    It stands alone, in the ``state`` stage: it is the passage's memory driven by the input's
    travel, where ``stick_slip`` is driven by its force. It cannot refine ``stick_slip``: a
    massless cable passes the measured input force to the contact whatever its stiffness, so
    the force-driven play is unchanged by it, and the stretch shows only against the travel (the
    backlash in displacement of Agrawal et al.'s cable-conduit model). The two agree where the
    measured force is the contact's and the cable linear; this block wins where the travel tells
    the contact's state better than the force does. ``C = 0``
    is the model without it, bit for bit (its limit ``C -> 0+`` holds the edge of the last
    motion through rests, where the base's Eq. (6) puts the ratio at 1: its fit starts at the
    probe). Needs the input's position.
    """

    name: ClassVar[str] = "cable_elasticity"
    effect: ClassVar[str] = "cable_elasticity"
    stage: ClassVar[str] = "state"
    param_names: ClassVar[tuple[str, ...]] = ("compliance",)
    units: ClassVar[dict[str, str]] = {"compliance": "rad/Q"}
    regressor: ClassVar[str] = "a residual after each reversal that fades over the input's travel, not its force"
    needs: ClassVar[tuple[str, ...]] = ("position",)

    def bounds(self, scale):
        # Up to a band as large as the largest output crossed over the whole travel: beyond, no edge is reached.
        return {"compliance": (0.0, scale["travel"] / scale["signal"])}

    def probe(self, scale):
        # Such a band crossed over 2 % of the travel (the bench's reversals cross ~90 % of theirs in ~4 %,
        # experiments/elastic_edge.py).
        return {"compliance": 0.02 * scale["travel"] / scale["signal"]}

    def initial(self, scale):
        # At C = 0 the reading jumps at every rest (see the docstring): start inside.
        return self.probe(scale)


def elastic_state(
    forward: NDArray, reverse: NDArray, travel: NDArray, compliance: float, reset, start, z0: float | None = None
) -> tuple[NDArray, float]:
    """The predicted side [Q] of :class:`CableElasticity`, shape (T,), and its state at the last frame.

    Parameters
    ----------
    forward, reverse : ndarray, shape (T,)
        The predicted side on the edge of forward and of reverse slip [Q].
    travel : ndarray, shape (T,)
        The input's position [rad].
    compliance : float
        ``C`` [rad/Q], ``> 0``.
    reset : ndarray of bool, shape (T,)
        Trajectory starts.
    start : ndarray, shape (T,)
        The edge each frame's log starts on: +1 forward, -1 reverse.
    z0 : float, optional
        The state before frame 0 (a previous call's), read where ``reset[0]`` is False.

    Returns
    -------
    (y, z)
        The predicted side [Q], and the play operator's output ``z = w - e`` at the last frame [Q].
    """
    centre = 0.5 * (forward + reverse)
    half = 0.5 * np.abs(reverse - forward)
    w = travel / compliance  # the force the travel puts into the cable [Q]
    # z = w - e; a log starts with e = start * h (on its first motion's edge).
    lo = np.where(reset, w - start * half, w - half)
    hi = np.where(reset, w - start * half, w + half)
    z = play_output(lo, hi, reset, z0)
    e = w - z
    # e / h times (forward - centre), written so that a band of zero width gives the centre.
    return centre + e * np.sign(forward - reverse), float(z[-1])


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

    def derive(self, inputs):
        inputs.speed()

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

    def derive(self, inputs):
        inputs.slip_state(scale_band(inputs))

    def load(self, inputs, values):
        return -values["f"] * inputs.slip_state(scale_band(inputs))


def scale_band(inputs) -> float:
    """The deadband of the direction of motion: twice the median non-zero step of the travel."""

    def compute():
        # The non-zero steps gathered slice by slice into one buffer, their median taken in
        # place: one whole-length array, not the four of abs(diff(x))[mask] and median's copy.
        x = inputs.travel()
        steps, n = np.empty(max(x.size - 1, 0)), 0
        for s in frame_slices(x.size - 1):
            part = np.abs(np.diff(x[s.start : s.stop + 1]))
            part = part[part > 0]
            steps[n : n + part.size] = part
            n += part.size
        return 2.0 * float(np.median(steps[:n], overwrite_input=True)) if n else 1e-12

    return inputs.memo("band", compute)


def make_block(effect: str | PassageBlock) -> PassageBlock:
    """The block of ``effect`` (ConfigError naming the known ones otherwise); a block is returned as it is."""
    return effect if isinstance(effect, PassageBlock) else BLOCKS[effect]()
