"""Blocks on the load cells' measurement chain: calibration, sampling instant and lag (:doc:`/guide/simulator`).

The simulator's three sensor-chain effects (:mod:`tendon_id.sim.sensor_chain`) act on the logged
streams only, never on the physics; each block here models one of them with the simulator's own
functions (:mod:`friction_models.load_cell`), so that with the true settings the model reads what
the simulator logs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from friction_models import first_order_inverse, first_order_lowpass, shifted_read
from tendon_id.errors import ConfigError
from tendon_id.zoo.blocks.base import Block

__all__ = ["ActuatorCells", "ClockSkew", "LoadCellDynamics"]


def _finite(block: str, name: str, value) -> float:
    try:
        out = float(value)
    except (TypeError, ValueError):
        out = np.nan
    if not np.isfinite(out):
        raise ConfigError(f"{block}.{name} must be a finite number, got {value!r}")
    return out


@dataclass(frozen=True, init=False)
class ActuatorCells(Block):
    """Gain and offset errors of the actuator-side load cells (:doc:`/guide/simulator` ``actuator_cells``).

    The cell of tendon ``i`` reads ``(1 + g_i) T + o_i`` (:func:`friction_models.gain_offset`);
    the block inverts it, ``T = (reading - o_i) / (1 + g_i)``, before the chain takes the
    logarithm.  The simulator draws one error per cell, set ``j`` and tendon ``i``; the block
    has one per tendon, applied to every set's cells alike.  The terminal labels see only the
    terminal set's cells (the chain of the last set), so a fit on them recovers that set's
    errors, and the joint-side predictions of the other sets read through those too.

    Parameters
    ----------
    n_tendons : int
        Tendons per set ``n``: the block has ``gain_1..gain_n`` and ``offset_1..offset_n``.  Default 3;
        a model sizes it to its robot when it fits (:meth:`started_from`).
    fixed : bool
        Hold the errors instead of fitting them.
    **cells : float
        ``gain_i``, relative gain (span) error of tendon ``i``'s cells [-], ``> -1``, and ``offset_i``,
        their zero offset [N].  Default 0.
    """

    name = "actuator_cells"
    effect = "actuator_cells"
    stage = "actuator"
    per_tendon = True
    regressor = "the actuator tension and a constant, per tendon: residual affine in the input, no trend in time"
    n_tendons: int = 3
    # The values, in param_names' order: a field, so that two blocks with other errors differ.
    cells: tuple[float, ...] = ()

    def __init__(self, n_tendons: int = 3, fixed: bool = False, **cells) -> None:
        if isinstance(n_tendons, bool) or int(n_tendons) != n_tendons or n_tendons < 2:
            raise ConfigError(f"{self.name}.n_tendons must be an integer >= 2, got {n_tendons!r}")
        n = int(n_tendons)
        tendons = range(1, n + 1)
        names = tuple(f"gain_{i}" for i in tendons) + tuple(f"offset_{i}" for i in tendons)
        unknown = sorted(set(cells) - set(names))
        if unknown:
            raise ConfigError(f"{self.name}: unknown setting {unknown[0]!r} for {n} tendons per set")
        values = tuple(_finite(self.name, p, cells.get(p, 0.0)) for p in names)
        for p, v in zip(names, values):
            if p.startswith("gain") and not v > -1.0:
                raise ConfigError(f"{self.name}.{p} must be > -1 (a cell that reads its load), got {v}")
            object.__setattr__(self, p, v)
        object.__setattr__(self, "n_tendons", n)
        object.__setattr__(self, "cells", values)
        object.__setattr__(self, "fixed", bool(fixed))
        object.__setattr__(self, "param_names", names)
        # The bounds hold ten of the simulator's default spreads (gain_sd 0.01, offset_sd 2 N) and more.
        object.__setattr__(
            self,
            "bounds",
            {**{f"gain_{i}": (-0.2, 0.2) for i in tendons}, **{f"offset_{i}": (-30.0, 30.0) for i in tendons}},
        )
        object.__setattr__(
            self, "probe", {**{f"gain_{i}": 0.01 for i in tendons}, **{f"offset_{i}": 2.0 for i in tendons}}
        )

    def neutral(self) -> dict[str, float]:
        return {p: 0.0 for p in self.param_names}

    def settings(self) -> dict:
        # A 3-tendon block saves as it did before the count could change.
        return {} if self.n_tendons == 3 else {"n_tendons": self.n_tendons}

    def started_from(self, geometry) -> ActuatorCells:
        """The block sized to ``geometry``'s tendons per set (:meth:`for_tendons`)."""
        return self.for_tendons(geometry.n_tendons)

    def for_tendons(self, n: int) -> ActuatorCells:
        """The block with ``n`` tendons' cells, its values kept where the tendon exists."""
        if n == self.n_tendons:
            return self
        kept = {p: v for p, v in self.initial().items() if int(p.rsplit("_", 1)[1]) <= n}
        return ActuatorCells(n_tendons=n, fixed=self.fixed, **kept)

    def param_tendon(self, param: str) -> int | None:
        return int(param.rsplit("_", 1)[1]) - 1  # gain_i, offset_i: tendon i's cells only

    def actuator(self, tension: NDArray, ctx, values: dict) -> NDArray:
        # ctx.tendons picks each propagated tendon's cell; the set axis shares it.
        gain = np.array([values[f"gain_{i + 1}"] for i in ctx.tendons], dtype=float)
        offset = np.array([values[f"offset_{i + 1}"] for i in ctx.tendons], dtype=float)
        if np.any(gain <= -1.0):
            raise ConfigError(f"{self.name}: a gain error must be > -1, got {gain.tolist()}")
        return (tension - offset) / (1.0 + gain)


@dataclass(frozen=True)
class ClockSkew(Block):
    """The terminal cells' stream sampled off the input streams' clock (:doc:`/guide/simulator` ``clock_skew``).

    The simulator logs at frame time ``t`` the signal of ``t + delta_s`` for stream ``s``
    (angles, actuator, terminal), by linear interpolation within each trajectory, held beyond its
    ends (:func:`friction_models.shifted_read`).  The model's inputs are the angle and actuator
    streams, so it predicts the terminal tension at their instant; the block reads that
    prediction at ``t + skew_s``, ``skew_s / dt`` frames off (fractions allowed, within each
    trajectory).  The simulator's setting is modelled by ``skew_s = terminal_s - delta_in`` when the
    angle and actuator streams share a skew ``delta_in``: exactly for ``delta_in = 0`` (its default,
    ``terminal_s = -0.05`` with the others 0, is ``skew_s = -0.05``, the terminal reading half a
    10 Hz frame old), else up to the trajectories' ends, where the streams are held, and the
    interpolation of a fraction of a frame.

    Parameters
    ----------
    skew_s : float
        Time offset of the terminal stream relative to the input streams [s]: positive, the
        terminal cells read later than their time stamp says.  Default 0.
    """

    name = "clock_skew"
    effect = "clock_skew"
    stage = "sensor"
    measurement_order = 1  # the acquisition samples the lagged signal, the calibration maps the sample
    regressor = "the rate of change of the predicted terminal tension: residual grows with speed"
    skew_s: float = 0.0
    param_names: tuple[str, ...] = ("skew_s",)
    bounds: dict = field(default_factory=lambda: {"skew_s": (-1.0, 1.0)})
    probe: dict = field(default_factory=lambda: {"skew_s": 0.05}, compare=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "skew_s", _finite(self.name, "skew_s", self.skew_s))

    def sensor(self, tension: NDArray, ctx, values: dict) -> NDArray:
        skew = float(values["skew_s"])
        if skew == 0.0:
            return tension
        return shifted_read(tension, skew / ctx.inputs.dt, ctx.inputs.reset)


#: Forms of :class:`LoadCellDynamics`, the default first.
LAG_FORMS = ("exact", "commuted")


@dataclass(frozen=True)
class LoadCellDynamics(Block):
    """First-order lag of every load cell (:doc:`/guide/simulator` ``load_cell_dynamics``).

    Each cell reads ``y[t] = a y[t-1] + (1 - a) T[t]``, ``a = exp(-dt / tau_s)``, started settled
    (``y = T``) at each trajectory's first frame (:func:`friction_models.first_order_lowpass`),
    the actuator-side cells and the terminal ones alike.  The block has two forms:

    * ``"exact"`` (default) undoes the lag on the actuator-side readings (the filter's exact inverse,
      :func:`friction_models.first_order_inverse`) and applies it to the predicted terminal
      reading: at the true settings it is the simulator.  The inverse amplifies the readings'
      noise by about ``(1 + a) / (1 - a)`` at the highest frequency (2.2 at the simulator's
      default, 0.1 s at 10 Hz; 4.1 at 0.2 s), and a stick/slip model ratchets on it: with the
      simulator's 1 N noise, the block at the true lag and law predicted the held-out
      terminal reading worse than no block at all (0.1 s: 2.0 against 1.6 N RMSE).
    * ``"commuted"`` feeds the lagged readings as they are and lags the wrap the
      capstan exponent scales instead (an ``exponent``-stage filter, :attr:`stage`).  A lag
      commutes with a ratio to first order: with ``H = 1 - tau d/dt + O(tau^2)``,
      ``H[r(alpha) T] = r(H alpha) H[T] + O(tau^2)``, so a terminal tension that the cells
      see through the same lag is the chain's output at a lagged wrap, fed the lagged input.
      Nothing is inverted, so nothing amplifies the noise; the wrap's cosine in the affine law
      is not lagged, which leaves out a fraction ``A alpha sin(alpha) / mu`` of the first-order
      term (a few percent at the snake's wraps).  On the withheld-effect benchmark's lags (5
      seeds; :doc:`/guide/benchmarks`) it ranked first in 5 of 5 at 0.1 s and 0.2 s, where the
      exact form did in 1 and 2, so it is the diagnosis's candidate.  Its chain runs on the
      lagged tensions, so its joint-side estimates (``predict``) lag too: a model for
      estimating tensions takes the exact form.

    ``tau_s = 0`` is no lag, exactly, in either form.

    Parameters
    ----------
    tau_s : float
        Time constant [s], ``>= 0``.  Default 0.
    form : {"exact", "commuted"}
        As above (a setting, not fitted).  Default ``"exact"``.
    """

    name = "load_cell_dynamics"
    effect = "load_cell_dynamics"
    stage = "exponent"
    also = ("actuator", "sensor")
    multiplier = False  # the commuted form's exponent hook is a filter over time
    measurement_order = 0  # the cell and its amplifier filter the force before anything else
    regressor = "the rate of tension change, at the cell's time scale: residual lags the terminal tension"
    tau_s: float = 0.0
    form: str = "exact"
    param_names: tuple[str, ...] = ("tau_s",)
    bounds: dict = field(default_factory=lambda: {"tau_s": (0.0, 2.0)})
    probe: dict = field(default_factory=lambda: {"tau_s": 0.1}, compare=False, repr=False)

    def __post_init__(self) -> None:
        tau = _finite(self.name, "tau_s", self.tau_s)
        if tau < 0:
            raise ConfigError(f"{self.name}.tau_s must be a time >= 0 in s, got {tau}")
        object.__setattr__(self, "tau_s", tau)
        if self.form not in LAG_FORMS:
            raise ConfigError(f"{self.name}.form must be one of {', '.join(LAG_FORMS)}, got {self.form!r}")

    def settings(self) -> dict:
        return {"form": self.form}

    @classmethod
    def localise(cls, model, inputs, A, B, values, residual: NDArray) -> LoadCellDynamics:
        """The diagnosis's candidate: the commuted form, which no noise amplification hides (above)."""
        return cls(form="commuted")

    def _lag(self, values: dict, form: str) -> float:
        """The time constant [s] where ``form`` is this block's, else 0 (the hook passes its array through)."""
        tau = _tau(values)
        return tau if self.form == form else 0.0

    def exponent(self, phi: NDArray, ctx, values: dict) -> NDArray:
        tau = self._lag(values, "commuted")
        return phi if tau == 0.0 else first_order_lowpass(phi, ctx.inputs.dt, tau, ctx.inputs.reset)

    def actuator(self, tension: NDArray, ctx, values: dict) -> NDArray:
        tau = self._lag(values, "exact")
        return tension if tau == 0.0 else first_order_inverse(tension, ctx.inputs.dt, tau, ctx.inputs.reset)

    def sensor(self, tension: NDArray, ctx, values: dict) -> NDArray:
        tau = self._lag(values, "exact")
        return tension if tau == 0.0 else first_order_lowpass(tension, ctx.inputs.dt, tau, ctx.inputs.reset)


def _tau(values: dict) -> float:
    tau = float(values["tau_s"])
    if not tau >= 0:
        raise ConfigError(f"load_cell_dynamics.tau_s must be a time >= 0 in s, got {tau}")
    return tau
