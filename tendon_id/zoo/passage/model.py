"""``passage-capstan``: one capstan passage on a bench, with the passage's effect blocks.

See :doc:`/guide/zoo` and :doc:`/guide/data`.

The base predicts the output side from the input side (``direction="forward"``, the default)
through the capstan law of :mod:`friction_models.passage`: a single tendon
(``quantity = "tension"``) or an antagonistic pair (``"torque"``), in the slip direction of the
input's motion. Blocks (:mod:`tendon_id.zoo.passage.blocks`) add what the base leaves out.

Why forward by default: the input side is what a robot measures (its motors' torques and
positions), and the output side, the force at the tool or joint, is what a user wants to know;
it is also the snake's direction (joint-side tensions from actuator-side ones).
``direction="inverse"`` predicts the input side instead: the torque a motor needs for a
desired output, as feedforward.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from friction_models.maxwell_slip import maxwell_slip_output
from friction_models.passage import pair_input, pair_output, tendon_input, tendon_output
from friction_models.play_operator import play_output
from tendon_id.checks import check_choice, check_count, check_positive
from tendon_id.data.passage import PassageRecording
from tendon_id.errors import ConfigError
from tendon_id.family.registry import family_named
from tendon_id.metrics import tendon_metrics
from tendon_id.zoo.estimator import Estimator
from tendon_id.zoo.passage.blocks import PASSAGE_BLOCKS, PassageBlock, elastic_state, make_block, scale_band
from tendon_id.zoo.passage.fitting import calibrate_passage, calibration_record
from tendon_id.zoo.passage.inputs import WINDOW_FRAMES, PassageInputs

DIRECTIONS = ("forward", "inverse")
#: The capstan law's parameters per quantity: [unit] (``Q``: the passage's quantity, N or N m).
#: ``offset`` and ``input_offset`` are the output and input sensors' zeros (a torque sensor's
#: drifts; a tension's is part of its calibration).
LAW_PARAMS = {
    "torque": {"gain": "-", "phi": "-", "pretension": "Q", "sharing": "-", "offset": "Q", "input_offset": "Q"},
    "tension": {"gain": "-", "phi": "-", "offset": "Q"},
}


class PassageModel(Estimator):
    """Base of the single-passage models: data checks, scoring (the estimator contract of the zoo)."""

    family = family_named("passage")
    #: The data's quantity the model was fitted on (``torque`` or ``tension``).
    quantity_: str | None = None

    @property
    def is_fitted(self) -> bool:
        return self.quantity_ is not None

    def inputs(self, data) -> PassageInputs:
        """``data`` as the model's :class:`PassageInputs`, checked against the fitted quantity."""
        self.check_fitted()
        inputs = data if isinstance(data, PassageInputs) else PassageInputs.from_recordings(data)
        if inputs.quantity != self.quantity_:
            raise ConfigError(
                f"the model was fitted on a {self.quantity_} passage, the data is a {inputs.quantity} one"
            )
        return inputs

    def target(self, data) -> NDArray:
        """The measured side this model predicts [N or N m], shape (T,)."""
        inputs = data if isinstance(data, PassageInputs) else PassageInputs.from_recordings(data)
        return inputs.output if self.direction == "forward" else inputs.input

    def score(self, data: PassageRecording | Sequence[PassageRecording]) -> dict[str, Any]:
        """``{"predicted": M}``: RMSE, R^2 and max error of the predicted side, after the warm-up."""
        inputs = self.inputs(data)
        keep = inputs.since_start >= float(self.warmup_s)
        if not keep.any():
            longest = max(b - a for a, b in inputs.trajectory_bounds) * inputs.dt
            raise ConfigError(
                f"warmup_s = {self.warmup_s} s leaves no frame to score: the longest trajectory lasts {longest:g} s"
            )
        pred = self.predict(inputs)[keep]
        return {"predicted": tendon_metrics(pred[:, None], self.target(inputs)[keep][:, None]), "side": self.side}

    @property
    def side(self) -> str:
        """``output`` (forward) or ``input`` (inverse): what :meth:`predict` returns."""
        return "output" if self.direction == "forward" else "input"


class PassageCapstan(PassageModel):
    """A capstan passage with effect blocks.

    Parameters
    ----------
    blocks : sequence of str
        Effect blocks (:data:`~tendon_id.zoo.passage.blocks.PASSAGE_BLOCKS`): ``stick_slip``,
        ``smooth_edge``, ``cable_elasticity``, ``position_torque``, ``velocity_friction``,
        ``load_coulomb``, ``input_cells``, ``clock_skew``.
    direction : {"forward", "inverse"}
        Predict the output from the input (default; see the module docstring), or the reverse.
    warmup_s : float
        Seconds at each trajectory's start left out of the fit and the score [s]: the friction
        state at a log's start is unknown until a first reversal.
    n_starts : int
        Starts of the fit (values of ``phi`` spread over its range).
    maxeval : int
        nlopt's objective evaluations per start (each with a gradient, which costs one model
        evaluation per parameter).
    """

    name: ClassVar[str] = "passage-capstan"

    def __init__(
        self,
        blocks: Sequence[str] = (),
        direction: str = "forward",
        warmup_s: float = 1.0,
        n_starts: int = 3,
        maxeval: int = 100,
    ):
        self.blocks = tuple(blocks)
        self.direction = direction
        self.warmup_s = warmup_s
        self.n_starts = n_starts
        self.maxeval = maxeval

    # ---- structure -------------------------------------------------------------------
    def check_settings(self) -> None:
        check_count("n_starts", self.n_starts, 1)
        check_count("maxeval", self.maxeval, 10)
        check_positive("warmup_s", self.warmup_s, "s", allow_zero=True)
        for b in self.block_objects:
            missing = [r for r in b.requires if r not in self.blocks]
            if missing:
                raise ConfigError(f"the {b.effect} block refines {', '.join(missing)}: add it too", param="blocks")

    @property
    def block_objects(self) -> list[PassageBlock]:
        check_choice("direction", self.direction, DIRECTIONS)
        out = [make_block(b) for b in self.blocks]
        if len({b.effect for b in out}) < len(out):
            raise ConfigError(f"a block is named twice in {list(self.blocks)}", param="blocks")
        states = [b.effect for b in out if b.stage == "state"]
        if len(states) > 1:
            # Two memories of one contact: the diagnosis does not try them together (they do not compose).
            raise ConfigError(f"{' and '.join(states)} are two states of one passage: use one", param="blocks")
        return out

    def with_blocks(self, *blocks: str | PassageBlock) -> PassageCapstan:
        """An unfitted copy with ``blocks`` (effect names or blocks) added."""
        effects = tuple(make_block(b).effect for b in blocks)
        return type(self)(
            **{**self.get_params(), "blocks": self.blocks + tuple(e for e in effects if e not in self.blocks)}
        )

    def param_labels(self, quantity: str) -> list[str]:
        """Names of the fitted parameters: the law's, then ``block:param``."""
        return list(LAW_PARAMS[quantity]) + [f"{b.effect}:{p}" for b in self.block_objects for p in b.param_names]

    # ---- the physics ----------------------------------------------------------------
    def edges(self, inputs: PassageInputs, theta: dict, *sigmas) -> tuple[NDArray, NDArray]:
        """The predicted side [Q], shape (T,), in each slip state of ``sigmas``.

        By default forward and reverse slip (+1, -1): the two edges of the stick/slip band. An
        array gives a slip state per frame (+1, -1 or 0, the paper's Eq. (6)). A torque pair's
        input is read from the input sensor's zero, ``input_offset``; an ``input`` block undoes
        the input sensor's reading first (forward) or reads the predicted input through it (inverse).
        """
        law = {k: theta[k] for k in LAW_PARAMS[inputs.quantity]}
        cells = [(b, _values(theta, b)) for b in self.block_objects if b.stage == "input"]
        u = inputs.input
        for b, values in cells:
            u = b.true_input(u, values)
        phi = law["phi"] * (inputs.wrap if inputs.wrap is not None else 1.0)
        load = theta["offset"] + sum(
            (b.load(inputs, _values(theta, b)) for b in self.block_objects if b.stage == "load"), 0.0
        )
        out = []
        for sigma in sigmas or (1.0, -1.0):
            if self.direction == "forward":
                y = (
                    pair_output(u - law["input_offset"], law["pretension"], phi, law["gain"], sigma, law["sharing"])
                    if inputs.quantity == "torque"
                    else tendon_output(u, phi, law["gain"], sigma)
                )
                out.append(y + load)
            else:
                y = inputs.output - load
                x = (
                    law["input_offset"] + pair_input(y, law["pretension"], phi, law["gain"], sigma, law["sharing"])
                    if inputs.quantity == "torque"
                    else tendon_input(y, phi, law["gain"], sigma)
                )
                for b, values in reversed(cells):
                    x = b.input_reading(x, values)
                out.append(x)
        return tuple(out)

    def reading(self, inputs: PassageInputs, theta: dict) -> NDArray:
        """The predicted side [Q], shape (T,), for parameters ``theta`` (``{label: value}``).

        Base: memoryless, on the edge of the current slip state (Eq. (6): ``sigma`` = +1 or -1
        while the input moves, 0 at rest). ``stick_slip``: held between the edges (play
        operator), from the edge of each log's first motion. ``smooth_edge``: the mean of play
        operators of spread widths instead (generalised Maxwell slip). ``cable_elasticity``:
        across the band as the input travels (an elasto-plastic element). A ``sensor`` block
        reads the result last.

        Evaluated in windows of :data:`WINDOW_FRAMES` (:meth:`reading_windows`), so that an
        hour's log costs one output array, not a dozen temporaries of its length.
        """
        y = None
        for a, b, part in self.reading_windows(inputs, theta):
            if b - a == inputs.n_frames:  # one window: the whole reading
                return part
            y = np.empty(inputs.n_frames) if y is None else y
            y[a:b] = part
        return y

    @property
    def streams(self) -> bool:
        """Whether the reading can be evaluated in windows of frames (every block streams)."""
        return all(b.streams for b in self.block_objects)

    def derive(self, inputs: PassageInputs) -> None:
        """Compute, on the whole ``inputs``, every derived array the reading reads (before windows)."""
        band = scale_band(inputs)
        effects = {b.effect for b in self.block_objects}
        if effects & {"stick_slip", "cable_elasticity"}:
            inputs.first_motion(band)
        if "stick_slip" not in effects:  # the memoryless edge (a cable_elasticity of compliance 0 is one)
            inputs.slip_state(band)
        for b in self.block_objects:
            b.derive(inputs)

    def reading_windows(self, inputs: PassageInputs, theta: dict, frames: int | None = None):
        """Yield ``(start, stop, y)``: the reading of frames ``start`` to ``stop - 1`` [Q], in order.

        Exactly :meth:`reading`'s numbers: the edges are per frame, the derived arrays are the
        whole inputs' (:meth:`derive`), and the play operator's output (each Maxwell-slip
        element's, the elastic state) is carried from one window to the next. A model with a
        block that does not stream (``clock_skew`` reads later frames) yields one window.
        """
        n, size = inputs.n_frames, int(frames or WINDOW_FRAMES)
        if n <= size or not self.streams:
            yield 0, n, self.reading_at(inputs, theta)[0]
            return
        self.derive(inputs)
        carry = None
        for a in range(0, n, size):
            b = min(a + size, n)
            y, carry = self.reading_at(inputs.window(a, b), theta, carry)
            yield a, b, y

    def reading_at(self, inputs: PassageInputs, theta: dict, carry=None) -> tuple[NDArray, Any]:
        """The reading of ``inputs`` (all of them, or a window) from the state ``carry``, and the state after it."""
        blocks = self.block_objects
        effects = {b.effect for b in blocks}
        compliance = theta.get("cable_elasticity:compliance", 0.0)
        if "stick_slip" in effects:
            forward, reverse = self.edges(inputs, theta)
            # A log starts on the edge of its first motion.
            on_edge = np.where(inputs.first_motion(scale_band(inputs)) > 0, forward, reverse)
            lo = np.where(inputs.reset, on_edge, np.minimum(forward, reverse))
            hi = np.where(inputs.reset, on_edge, np.maximum(forward, reverse))
            width = theta.get("smooth_edge:width", 0.0)
            if width > 0:
                y, _, carry = maxwell_slip_output(lo, hi, inputs.reset, width, y0=carry, with_state=True)
            else:
                y = play_output(lo, hi, inputs.reset, carry)
                carry = y[-1]
        elif "cable_elasticity" in effects and compliance > 0:
            forward, reverse = self.edges(inputs, theta)
            start = inputs.first_motion(scale_band(inputs))
            y, carry = elastic_state(forward, reverse, inputs.position, compliance, inputs.reset, start, carry)
        else:  # no memory (a cable_elasticity of compliance 0 is none)
            (y,) = self.edges(inputs, theta, inputs.slip_state(scale_band(inputs)))
        for b in blocks:
            if b.stage == "sensor":
                y = b.sensor(inputs, y, _values(theta, b), self.direction)
        return y, carry

    # ---- estimator -------------------------------------------------------------------
    def fit(self, data: PassageRecording | Sequence[PassageRecording]) -> PassageCapstan:
        """Fit the law and the blocks' parameters (:mod:`~tendon_id.zoo.passage.fitting`); returns ``self``."""
        self.check_settings()
        inputs = data if isinstance(data, PassageInputs) else PassageInputs.from_recordings(data)
        data = None  # recordings handed over (the CLI's) are freed for the calibration: it reads the signals
        for b in self.block_objects:
            b.check(inputs)
        fit = calibrate_passage(self, inputs)
        self.theta_ = fit.values
        self.quantity_ = inputs.quantity
        self.calibration_ = calibration_record(fit)
        return self

    def predict(self, data) -> NDArray:
        """The predicted side (output when forward) [N or N m], shape (T,)."""
        inputs = self.inputs(data)
        return self.reading(inputs, self.theta_)

    def _state(self):
        return {"quantity": self.quantity_, "theta": self.theta_, "calibration": self.calibration_}, {}

    def _restore(self, state, arrays):
        self.quantity_ = check_choice("state.quantity", state["quantity"], LAW_PARAMS, what="quantity")
        theta = state["theta"]
        if not isinstance(theta, dict):
            raise ConfigError(f"state.theta must be an object of parameter values, got {type(theta).__name__}")
        need = list(LAW_PARAMS[self.quantity_]) + [f"{b.effect}:{p}" for b in self.block_objects for p in b.param_names]
        missing = [k for k in need if k not in theta]
        if missing:
            raise ConfigError(f"state.theta has no {missing[0]!r}, which this model's law and blocks need")
        self.theta_ = {k: float(v) for k, v in theta.items()}
        bad = [k for k in need if not math.isfinite(self.theta_[k])]
        if bad or self.theta_["gain"] <= 0 or self.theta_["phi"] < 0:
            # the capstan law: a positive gain and a non-negative exponent mu*alpha (Euler-Eytelwein)
            raise ConfigError(f"state.theta holds a value no fit gives ({(bad or ['gain or phi'])[0]})")
        self.calibration_ = state.get("calibration", {})


def _values(theta: dict, block: PassageBlock) -> dict[str, float]:
    return {p: theta[f"{block.effect}:{p}"] for p in block.param_names}


__all__ = ["DIRECTIONS", "LAW_PARAMS", "PASSAGE_BLOCKS", "PassageCapstan", "PassageModel"]
