"""The passage's blocks on its sensors: the input sensor's calibration and the output stream's instant.

Two of the snake's sensor-chain effects (:mod:`tendon_id.zoo.blocks.sensors`), for a bench's one
passage: they act on what the sensors read, never on the physics. ``input_cells`` is in the
``input`` stage (the input side's reading is undone before the law), ``clock_skew`` in the
``sensor`` stage (the predicted side's reading, last). See :mod:`tendon_id.zoo.passage.blocks`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from friction_models import shifted_read
from tendon_id.zoo.passage.blocks import PassageBlock

__all__ = ["ClockSkew", "InputCells", "SKEW_FRAMES"]

#: Half-width of ``clock_skew``'s range [sample periods] (see :class:`ClockSkew`).
SKEW_FRAMES = 5.0


@dataclass(frozen=True)
class InputCells(PassageBlock):
    """Gain and offset errors of the input-side sensor: it reads ``(1 + g) x + o`` of the true ``x``.

    The passage's counterpart of the snake's ``actuator_cells`` (the simulator's model of a load
    cell's calibration, :func:`friction_models.gain_offset`): the block undoes it on the input,
    ``x = (u - o) / (1 + g)``, before the capstan law (forward), or applies it to the predicted
    input (``direction="inverse"``). ``g`` [-] and ``o`` [Q], 0 each is no error, bit for bit.

    What the data can pin: the passage's law is linear in its input for a single tendon, so
    ``1 + g`` trades with the law's ``gain`` exactly there, while ``o`` moves the band's zero
    (the band's width grows with ``u - o``) and is pinned. An antagonistic pair is homogeneous
    of degree one in its input and pretension (:mod:`friction_models.passage`), and its law
    already holds the input sensor's zero ``input_offset``: on a torque pair the block adds
    nothing the law cannot do (the diagnosis reports it confounded).
    """

    name: ClassVar[str] = "input_cells"
    effect: ClassVar[str] = "input_cells"
    stage: ClassVar[str] = "input"
    param_names: ClassVar[tuple[str, ...]] = ("gain", "offset")
    units: ClassVar[dict[str, str]] = {"gain": "-", "offset": "Q"}
    regressor: ClassVar[str] = "the input and a constant carried through the band: residual affine in the input"

    def bounds(self, scale):
        # As the snake's actuator_cells: a span error of 20 % at most; a zero up to half the input's range.
        return {"gain": (-0.2, 0.2), "offset": (-0.5 * scale["input"], 0.5 * scale["input"])}

    def probe(self, scale):
        # A 1 % span error and a zero 2 % of the input's largest value.
        return {"gain": 0.01, "offset": 0.02 * scale["input"]}

    def true_input(self, u, values):
        g, o = values["gain"], values["offset"]
        return u if g == 0.0 and o == 0.0 else (u - o) / (1.0 + g)

    def input_reading(self, x, values):
        g, o = values["gain"], values["offset"]
        return x if g == 0.0 and o == 0.0 else (1.0 + g) * x + o


@dataclass(frozen=True)
class ClockSkew(PassageBlock):
    """The output stream sampled off the input stream's clock: the output reads ``skew_s`` late.

    The snake's ``clock_skew`` (:class:`tendon_id.zoo.blocks.ClockSkew`) for a passage: the
    output sensor logs at frame time ``t`` the signal of ``t + skew_s``. The model predicts the
    output at the input's instant, and the block reads that prediction ``skew_s / dt`` frames
    later (fractions by linear interpolation within each log, held at its ends:
    :func:`friction_models.shifted_read`; ``dt`` is the data's sample period). Predicting the
    input (``direction="inverse"``), the prediction is read ``skew_s`` earlier instead.

    ``skew_s`` [s], 0 is no skew, bit for bit. Its range is ``SKEW_FRAMES`` = 5 sample periods
    either side: a skew between two streams of one acquisition is an amplifier's group delay,
    a sample-and-hold or a buffer one frame off, a few periods at most (5 ms on a 1 kHz bench);
    a longer lag is a delay or a sensor's dynamics, which a skew would only mimic.
    """

    name: ClassVar[str] = "clock_skew"
    effect: ClassVar[str] = "clock_skew"
    stage: ClassVar[str] = "sensor"
    param_names: ClassVar[tuple[str, ...]] = ("skew_s",)
    units: ClassVar[dict[str, str]] = {"skew_s": "s"}
    regressor: ClassVar[str] = "the rate of change of the predicted output: residual grows with its speed"
    #: It reads up to SKEW_FRAMES frames ahead of each frame.
    streams: ClassVar[bool] = False

    def bounds(self, scale):
        return {"skew_s": (-SKEW_FRAMES * scale["dt"], SKEW_FRAMES * scale["dt"])}

    def probe(self, scale):
        return {"skew_s": scale["dt"]}

    def sensor(self, inputs, y, values, direction):
        skew = float(values["skew_s"])
        if skew == 0.0:
            return y
        return shifted_read(y, (skew if direction == "forward" else -skew) / inputs.dt, inputs.reset)
