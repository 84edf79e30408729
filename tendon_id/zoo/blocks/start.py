"""The stick state a logged trajectory inherits from motion that was never logged (:doc:`/guide/diagnosis`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tendon_id.zoo.blocks.base import Block


@dataclass(frozen=True)
class StartState(Block):
    """An observer of each trajectory's initial stick state, from its first terminal reading.

    A capstan model with hysteresis starts every trajectory taut, each guide on its forward-slip
    edge. A log cut from a longer session starts instead in whatever state the unlogged motion
    before it left (the recipe's ``session = "continuous"``, :doc:`/guide/simulator`), anywhere
    in the chain's dead zone: the joint side lies between ``T_in e^{-sum phi}`` and
    ``T_in e^{+sum phi}`` (Kaneko 1991). No estimator that sees a log only from its first frame
    can know that state; an observer can settle it from a measurement. This one places every
    guide of the terminal set's tendons at the same share ``f`` of its band, ``x - phi + 2 f phi``,
    a state the chain can hold, with ``f`` chosen so that the predicted joint side equals the
    first terminal reading of the log (clipped to the dead zone). The sets the labels do not see
    start taut as before. Nothing is fitted: it is a structure, and the diagnosis compares the
    held-out error with and without it. It reads the terminal cell at each log's first frame,
    as an observer in a deployed estimator would at start-up; the sensor blocks' bias is not
    undone first, so a biased cell leaves part of its bias in ``f``.

    It acts with the hysteresis block's and the elastic tendon block's compiled pass over the
    whole chain (:meth:`~tendon_id.zoo.blocks.Block.propagate_series`), not with blocks that act on
    one guide's edges or output.
    """

    name = "start_state"
    effect = "start_state"
    stage = "start"
    requires = ("stick_slip",)
    whole_chain = True
    regressor = "the log's first seconds: residual of the sign of the inherited state, decaying as the log moves on"

    def start(self, log_in: NDArray, phi: NDArray, n_pass: NDArray, ctx, values: dict) -> NDArray:
        """Share ``f`` of the band each column restarts at, shape (T, M) (read at restarts only).

        ``log_in`` (T, M) is ``ln T`` entering the first guide, ``phi`` (T, K, M) each guide's
        exponent and ``n_pass`` (M,) how many guides each column passes; columns are
        ``(set, tendon)`` pairs of ``ctx.sets`` and ``ctx.tendons``, set-major.
        """
        inputs = ctx.inputs
        t, k, m = phi.shape
        sets, tendons = np.asarray(ctx.sets), np.asarray(ctx.tendons)
        share = np.zeros((t, m))
        terminal_set = inputs.n_modules - 1
        cols = np.flatnonzero(np.repeat(sets == terminal_set, len(tendons)))
        if cols.size == 0:
            return share
        passed = np.arange(k)[None, :, None] < n_pass[None, None, cols]
        width = 2.0 * np.sum(np.where(passed, phi[:, :, cols], 0.0), axis=1)  # the dead zone, (T, C) [ln N]
        reading = inputs.terminal[:, np.tile(tendons, len(sets))[cols]]
        with np.errstate(divide="ignore", invalid="ignore"):
            f = (np.log(np.maximum(reading, 1e-9)) - (log_in[:, cols] - 0.5 * width)) / width
        share[:, cols] = np.clip(np.nan_to_num(f, nan=0.0), 0.0, 1.0)
        return share
