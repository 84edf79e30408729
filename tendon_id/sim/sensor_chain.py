"""Sensors as they are built: calibration errors, lag and clock skew of the logged streams (:doc:`/guide/simulator`).

Between the truth and the noise of :class:`~tendon_id.sim.Sensors`, each stream of a recording
passes the effects of its sensors that are on:

* the load cells' lag (``load_cell_dynamics``, actuator-side and terminal cells);
* the instant each stream is sampled at (``clock_skew``, all three streams);
* the actuator-side cells' gain and offset (``actuator_cells``).

Each is linear and keeps a constant signal, so the order only matters to rounding and near a
trajectory's ends; it is that of the physical chain: the cell and its amplifier filter the
force, the acquisition samples the filtered signal, and the calibration maps the sample to
newtons.  The terminal cells' ``sensor_bias`` and every cell's noise come after, in
:func:`tendon_id.sim.simulate`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from friction_models import first_order_lowpass, gain_offset, shifted_read
from tendon_id.errors import ConfigError
from tendon_id.sim.effects import Effects
from tendon_id.sim.sensor_effects import ActuatorCells

__all__ = ["SENSOR_CHAIN_EFFECTS", "SensorSignals", "cell_errors", "sensor_signals"]

#: The effects applied here, to the logged streams after the transmission; the truth physics never sees them.
SENSOR_CHAIN_EFFECTS = ("actuator_cells", "clock_skew", "load_cell_dynamics")
#: Tag of the random streams of the cells' errors: drawn from the seed alone, the same cells in every protocol.
_CELLS_STREAM = 0xCE11


@dataclass(frozen=True)
class SensorSignals:
    """The streams as the sensors present them, before noise, range and quantisation.

    Attributes
    ----------
    theta : ndarray, shape (T, N, 2)
        Joint angles the encoders sample [rad].
    actuator : ndarray, shape (T, N, 3)
        Actuator-side readings [N].
    terminal : ndarray, shape (T, 3)
        Terminal readings [N] (before ``sensor_bias``).
    truth : dict
        Plain-JSON record of drawn sensor parameters (``{"actuator_cells": {"gain": ..., "offset": ...}}``),
        empty when nothing was drawn or given.
    """

    theta: NDArray[np.float64]
    actuator: NDArray[np.float64]
    terminal: NDArray[np.float64]
    truth: dict = field(default_factory=dict)


def _explicit(name: str, value, n: int, nt: int) -> NDArray[np.float64]:
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        return np.full((n, nt), float(arr))
    if arr.shape != (n, nt):
        raise ConfigError(
            f"actuator_cells.{name} needs one row of {nt} values per set ({n} rows for this robot), "
            f"got shape {arr.shape}"
        )
    return arr


def cell_errors(seed: int, n_modules: int, cells: ActuatorCells, n_tendons: int = 3) -> tuple[NDArray, NDArray]:
    """Gain error [-] and offset [N] of each actuator-side cell, each shape (N, n) (set ``j``, tendon ``i``).

    Explicit values of ``cells`` are taken as given; the others are drawn from ``seed`` alone,
    one independent stream for the gains and one for the offsets, filled set by set: the
    cells of a robot with fewer modules are the first rows of a longer one's, and every protocol
    of a seed reads through the same cells.
    """
    n, nt = int(n_modules), int(n_tendons)
    if cells.gain is not None:
        gain = _explicit("gain", cells.gain, n, nt)
    else:
        gain = cells.gain_sd * np.random.default_rng([int(seed), _CELLS_STREAM, 0]).standard_normal((n, nt))
    if cells.offset is not None:
        offset = _explicit("offset", cells.offset, n, nt)
    else:
        offset = cells.offset_sd * np.random.default_rng([int(seed), _CELLS_STREAM, 1]).standard_normal((n, nt))
    if np.any(gain <= -1.0):
        raise ConfigError("actuator_cells: a gain error of -1 or below reads no load; lower gain_sd")
    return gain, offset


def sensor_signals(
    theta: NDArray,
    actuator: NDArray,
    terminal: NDArray,
    starts: NDArray,
    effects: Effects,
    dt: float,
    seed: int,
) -> SensorSignals:
    """The noise-free truth of each logged stream, as its sensors present it.

    With none of :data:`SENSOR_CHAIN_EFFECTS` on, the inputs come back unchanged (the same arrays).

    Parameters
    ----------
    theta : ndarray, shape (T, N, 2)
        True joint angles of the logged frames [rad].
    actuator : ndarray, shape (T, N, 3)
        True actuator-side tensions [N].
    terminal : ndarray, shape (T, 3)
        True terminal (joint-side) tensions of the last set [N].
    starts : ndarray of bool, shape (T,)
        True at each trajectory's first frame: lag and interpolation restart there.
    effects : Effects
        The recording's effects (those not in :data:`SENSOR_CHAIN_EFFECTS` are ignored).
    dt : float
        Sample period [s].
    seed : int
        The recording's seed (draws the cells' errors).
    """
    truth: dict = {}
    if "load_cell_dynamics" in effects:
        cells = effects.get("load_cell_dynamics")
        for _ in range(cells.order):  # order 2: two stages of half the time constant, the same mean delay
            actuator = first_order_lowpass(actuator, dt, cells.tau_s / cells.order, starts)
            terminal = first_order_lowpass(terminal, dt, cells.tau_s / cells.order, starts)
    if "clock_skew" in effects:
        skew = effects.get("clock_skew")
        theta = _skewed(theta, skew.angles_s, dt, starts)
        actuator = _skewed(actuator, skew.actuator_s, dt, starts)
        terminal = _skewed(terminal, skew.terminal_s, dt, starts)
    if "actuator_cells" in effects:
        gain, offset = cell_errors(seed, actuator.shape[1], effects.get("actuator_cells"), actuator.shape[2])
        actuator = gain_offset(actuator, gain, offset)
        truth["actuator_cells"] = {"gain": gain.tolist(), "offset": offset.tolist()}
    return SensorSignals(theta=theta, actuator=actuator, terminal=terminal, truth=truth)


def _skewed(x: NDArray, skew_s: float, dt: float, starts: NDArray) -> NDArray:
    """``x`` read ``skew_s`` seconds off its time stamps (:func:`friction_models.shifted_read`)."""
    if skew_s == 0.0:
        return x
    return shifted_read(x, skew_s / dt, starts)
