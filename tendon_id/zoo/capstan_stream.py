"""Streaming capstan models, one frame at a time: the law of a guide needs nothing from the past but its play state.

A capstan model whose blocks act on one frame alone (the routing wrap, the contact gate) and
on the guide's stick/slip (the play operator of ``capstan-nonsmooth``) streams with O(1) work
and memory per frame: per guide, set and tendon, the play operator's last output ``y``
[ln N].  Blocks that filter over time, read the sliding history or undo a load cell's
dynamics keep more state than that; a model with one of them does not stream (yet), and
says which.

The exponent of each frame is computed by the model's own blocks (as batch prediction does),
so streaming and :meth:`~tendon_id.zoo.capstan.CapstanModel.predict` agree to rounding
(``tests/zoo/test_capstan_stream.py``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tendon_id.errors import ConfigError
from tendon_id.zoo.inputs import TransmissionInputs

__all__ = ["STREAMED_BLOCKS", "CapstanStream", "unstreamed_blocks"]

#: Blocks a streamed capstan model may have: each acts on one frame alone, or (hysteresis) through
#: the play operator's state, which the stream carries.
STREAMED_BLOCKS = ("routing", "contact", "hysteresis")


def unstreamed_blocks(model) -> list[str]:
    """Names of ``model``'s blocks that the frame-by-frame law does not cover (empty: it streams)."""
    return [b.name for b in model.block_objects if b.name not in STREAMED_BLOCKS]


class CapstanStream:
    """``step(angles, actuator) -> (N, m)`` joint-side estimates [N] of a fitted capstan model.

    Parameters
    ----------
    model : CapstanModel
        A fitted model whose blocks are all in :data:`STREAMED_BLOCKS`.

    Raises
    ------
    ConfigError
        Naming the blocks that do not stream.
    """

    def __init__(self, model):
        model.check_fitted()
        others = unstreamed_blocks(model)
        if others:
            raise ConfigError(
                f"this {model.name} model has the block(s) {', '.join(others)}, which keep state over time or act "
                f"on the readings; only a capstan model with {', '.join(STREAMED_BLOCKS)} blocks streams frame by frame"
            )
        self.model = model
        self.values = model.block_params_
        self.hysteresis = any(b.stage == "propagate" for b in model.block_objects)
        self.reset()

    def reset(self) -> None:
        """Start a new trajectory: every guide's play operator restarts on its forward-slip edge."""
        self.y: NDArray | None = None

    def step(self, angles: NDArray, actuator: NDArray) -> NDArray:
        """One frame: joint angles (N, 2) [rad] and actuator-side tensions (N, m) [N] in; ``T_hat[j, j]`` (N, m) out."""
        angles = np.asarray(angles, dtype=float)
        actuator = np.asarray(actuator, dtype=float)
        n, m = actuator.shape
        model = self.model
        one = TransmissionInputs(
            angles=angles[None],
            actuator=actuator[None],
            terminal=np.ones((1, m)),
            reset=np.array([self.y is None]),
            clock=np.zeros(1),
            dt=1.0,  # no streamed block reads time
            geometry=model.geometry_,
        )
        phi = np.broadcast_to(model.exponent(one, model.A_, model.B_, self.values)[0], (n - 1, n, m))
        x = np.log(actuator)
        y_new = np.zeros((n - 1, n, m))
        for g in range(n - 1):
            s = slice(g + 1, n)  # set j (index j - 1) passes guide k = g + 1 iff k < j
            lo, hi = x[s] - phi[g, s], x[s] + phi[g, s]
            y = lo if self.y is None or not self.hysteresis else np.minimum(np.maximum(self.y[g, s], lo), hi)
            y_new[g, s] = y
            x[s] = y
        self.y = y_new
        est = np.exp(x)
        est[0] = actuator[0]  # set 1 passes no guide: exactly, not exp(log(.))
        return est
