"""Per-guide slip blocks: the edges of a guide's stick band and the step between them."""

from __future__ import annotations

from dataclasses import dataclass, field

from numpy.typing import NDArray

from friction_models import bending_loss, edges_with_loss
from friction_models.play_operator import play_output
from tendon_id.zoo.blocks.base import Block


@dataclass(frozen=True)
class Hysteresis(Block):
    """Stick/slip of the nonsmooth capstan: the log-domain play operator (paper §III-B, ref. [12])."""

    name = "hysteresis"
    effect = "stick_slip"
    stage = "propagate"
    regressor = "hysteretic minus forward-slip output: residual jumps at motion reversals"

    def propagate(self, lo: NDArray, hi: NDArray, ctx, values: dict) -> NDArray:
        return play_output(lo, hi, ctx.inputs.reset)


@dataclass(frozen=True)
class BendingStiffness(Block):
    """A tension-independent loss ``dT_b * alpha`` [N] per guide (DESIGN §5 ``bending_stiffness``).

    The loss widens the guide's slip band (:func:`friction_models.edges_with_loss`).

    Parameters
    ----------
    dT_b : float
        Loss per radian of wrap [N/rad].
    """

    name = "bending_stiffness"
    effect = "bending_stiffness"
    stage = "edges"
    regressor = "wrap over tension: log-ratio residual scales like 1/T"
    dT_b: float = 0.0
    param_names: tuple[str, ...] = ("dT_b",)
    bounds: dict = field(default_factory=lambda: {"dT_b": (0.0, 50.0)})
    probe: dict = field(default_factory=lambda: {"dT_b": 4.0}, compare=False, repr=False)

    def edges(self, lo: NDArray, hi: NDArray, ctx, values: dict) -> tuple[NDArray, NDArray]:
        return edges_with_loss(lo, hi, bending_loss(ctx.guide_alpha, values["dT_b"]))
