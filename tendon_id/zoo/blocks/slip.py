"""Per-guide slip blocks: the edges of a guide's stick band and the step between them."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from friction_models import bending_loss, edges_with_loss
from friction_models.kernels import play_series
from friction_models.maxwell_slip import maxwell_slip_output
from friction_models.play_operator import play_output
from tendon_id.zoo.blocks.base import Block

#: Widths of the smooth edge a diagnosis tries as the start of its fit (:meth:`SmoothEdge.localise`).
START_WIDTHS = (0.0, 0.1, 0.2, 0.4, 0.7)


@dataclass(frozen=True)
class Hysteresis(Block):
    """Stick/slip of the nonsmooth capstan: the log-domain play operator (paper §III-B, ref. [12])."""

    name = "hysteresis"
    effect = "stick_slip"
    stage = "propagate"
    regressor = "hysteretic minus forward-slip output: residual jumps at motion reversals"

    def propagate(self, lo: NDArray, hi: NDArray, ctx, values: dict) -> NDArray:
        return play_output(lo, hi, ctx.inputs.reset)

    def propagate_series(self, log_in, phi, n_pass, ctx, values, keep_chain, start=None):
        # One compiled pass over frames for all guides in series, the same bits as guide by guide.
        return play_series(log_in, phi, n_pass, ctx.inputs.reset, keep_chain, start)


@dataclass(frozen=True)
class SmoothEdge(Block):
    """A smooth edge of the stick/slip band: the guide's contact slips gradually (``stick_slip.edge = "smooth"``).

    The simulator's smooth edge (:class:`tendon_id.sim.effects.StickSlip`): the tendon's
    compliance along the contact lets it slip element by element, the generalised
    Maxwell-slip model (Al-Bender, Lampaert & Swevers 2005) as a sum of play operators whose
    half-widths spread over ``(1 - width, 1 + width)`` times the band's
    (:func:`friction_models.maxwell_slip`). It refines ``stick_slip`` (the
    hysteresis block) and sets the step in its place.

    Parameters
    ----------
    width : float
        Width of the edge, a fraction of the stick band [-], in [0, 1]; the default 0 is the
        sharp play operator, so a model with this block starts from its base model's fit.
    """

    name = "smooth_edge"
    effect = "smooth_edge"
    stage = "propagate"
    requires = ("stick_slip",)
    regressor = "smooth minus sharp hysteresis: residual where a guide's slip sets in after a reversal"
    width: float = 0.0
    param_names: tuple[str, ...] = ("width",)
    bounds: dict = field(default_factory=lambda: {"width": (0.0, 1.0)})
    # The probe is the simulator's default width, the bench's (tendon_id.sim.effects.BENCH_EDGE_WIDTH).
    probe: dict = field(default_factory=lambda: {"width": 0.21}, compare=False, repr=False)

    def propagate(self, lo: NDArray, hi: NDArray, ctx, values: dict) -> NDArray:
        width = float(values["width"])
        if width <= 0:
            return play_output(lo, hi, ctx.inputs.reset)
        return maxwell_slip_output(lo, hi, ctx.inputs.reset, min(width, 1.0))[0]

    @classmethod
    def localise(cls, model, inputs, A, B, values, residual: NDArray) -> SmoothEdge:
        """The width of :data:`START_WIDTHS` with the least squared error [N^2] of the base's law on ``inputs``.

        A smooth edge changes the reading only where a guide's slip sets in, over a share of the
        band that grows with the width, so the loss is flat at width 0 (its slope there is 0) and
        a fit started there stays; width 0 is in the grid, so where no width helps it starts from the base.
        """
        augmented = model.with_blocks(cls())
        keep = inputs.since_start >= float(model.warmup_s)

        def sse(width: float) -> float:
            pred = augmented.terminal_reading(inputs, A, B, {**values, cls.name: {"width": width}})
            return float(np.nansum((pred - inputs.terminal)[keep] ** 2))

        return cls(width=min(START_WIDTHS, key=sse))


@dataclass(frozen=True)
class BendingStiffness(Block):
    """A tension-independent loss ``dT_b * alpha`` [N] per guide (:doc:`/guide/simulator` ``bending_stiffness``).

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
