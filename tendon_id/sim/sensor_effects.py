"""Effects of the load cells, the clocks and the friction's drift (:doc:`/guide/simulator`), and their parameters.

The measurement chain as it is built, and friction that runs in and wears: frozen dataclasses of
documented parameters, validated on construction, as every effect of :mod:`tendon_id.sim.effects`
(which registers them).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tendon_id.errors import ConfigError

__all__ = ["ActuatorCells", "ClockSkew", "FrictionDrift", "LoadCellDynamics", "SensorBias"]


@dataclass(frozen=True)
class SensorBias:
    """``sensor_bias``: offset, gain error and drift of the terminal load cells.

    ``T_meas = (1 + gain) T + offset + drift * t_clock``, where ``t_clock`` runs
    over the whole session (trajectories are recorded back to back).

    Parameters
    ----------
    offset : float
        Zero offset [N]. Default 3.0.
    gain : float
        Relative gain error [-]. Default 0.03.
    drift : float
        Zero drift [N/s]. Default 0.002 (7 N per hour).
    drift_form : {"linear", "warm_up"}
        ``"linear"`` (default): ``drift * t``. ``"warm_up"``: the zero drifts while the bridge
        warms up and settles, ``drift * t_w (1 - exp(-t / t_w))``, with the same initial rate: the
        first-order thermal settling of a strain-gauge bridge after power-on (HBM, "Warm-up drift
        of strain gauge transducers", technical note; the data sheets state a warm-up time). The
        diagnosis's bias block has the linear form: this one is the benchmark's case of the right
        family in another form.
    warm_up_s : float
        The warm-up time constant ``t_w`` [s], ``> 0``. Default 120.
    """

    offset: float = 3.0
    gain: float = 0.03
    drift: float = 0.002
    drift_form: str = "linear"
    warm_up_s: float = 120.0

    def __post_init__(self) -> None:
        if not self.gain > -1:
            raise ConfigError("sensor_bias.gain must be > -1")
        if self.drift_form not in ("linear", "warm_up"):
            raise ConfigError(f"sensor_bias.drift_form must be 'linear' or 'warm_up', got {self.drift_form!r}")
        if not (isinstance(self.warm_up_s, (int, float)) and 0 < self.warm_up_s < np.inf):
            raise ConfigError(f"sensor_bias.warm_up_s must be a positive time in s, got {self.warm_up_s!r}")


def _cell_values(name: str, value) -> float | tuple[tuple[float, ...], ...] | None:
    """An explicit per-cell setting: None, one number for every cell, or rows of n (set j, tendon i)."""
    if value is None:
        return None
    try:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            out = float(value)
            finite = bool(np.isfinite(out))
        else:
            out = tuple(tuple(float(v) for v in row) for row in value)
            finite = bool(np.all(np.isfinite(out))) and len(out) > 0 and all(len(row) == len(out[0]) for row in out)
    except (TypeError, ValueError):
        raise ConfigError(
            f"actuator_cells.{name} must be a number or a list of rows of numbers, one per tendon (set, tendon), "
            f"got {value!r}"
        ) from None
    if not finite:
        raise ConfigError(
            f"actuator_cells.{name} needs finite values in rows of equal length (one per tendon), got {value!r}"
        )
    return out


@dataclass(frozen=True)
class ActuatorCells:
    """``actuator_cells``: gain and offset errors of the actuator-side load cells.

    The cell of tendon ``i`` of set ``j`` reads ``(1 + g_ji) T + o_ji`` before its noise.  These
    readings are every model's input, while the truth transmission runs on the true tensions.
    The errors are drawn once per seed, the same cells in every protocol of it
    (``g ~ N(0, gain_sd^2)``, ``o ~ N(0, offset_sd^2)``), or given; the recording's metadata
    keeps the values under ``sensor_truth``.

    Parameters
    ----------
    gain_sd : float
        Standard deviation of the relative gain (span) error [-], in ``[0, 0.2]``. Default 0.01,
        an assumed magnitude (the paper gives no number): a cell's span is calibrated with the
        load on its axis, and in use departs from it by how the load enters the cell (VPG
        Transducers, Technical Note VPGT-02, "Load cell accuracy in relation to the conditions of
        use"); an in-line cell on a tendon is loaded through its end fittings.  1 % is well above
        a data sheet's combined error (non-linearity, hysteresis, repeatability: a few tenths of
        a percent of rated output or less), which a calibration on the cell's axis achieves.
    offset_sd : float
        Standard deviation of the zero offset [N], ``>= 0``. Default 2.0, 0.4 % of the paper's
        500 N range: the cells are tared unloaded, and the zero then moves with temperature
        (HBM, "Temperature coefficient of the zero point": below 0.05 % of the nominal force per
        10 K for modern force transducers, 0.25 N per 10 K here) and by what mounting and
        pretensioning the tendon leave in the cell, which a tare of the bare cell cannot remove.
    gain : float or list of rows of 3 floats, optional
        Explicit gain errors [-] instead of drawn ones: one for every cell, or one row per set
        (``N`` rows, tendons along a row); each ``> -1``.
    offset : float or list of rows of 3 floats, optional
        Explicit offsets [N], as ``gain``.
    """

    gain_sd: float = 0.01
    offset_sd: float = 2.0
    gain: object = None
    offset: object = None

    def __post_init__(self) -> None:
        if not (isinstance(self.gain_sd, (int, float)) and 0 <= self.gain_sd <= 0.2):
            raise ConfigError(f"actuator_cells.gain_sd must be a relative error in [0, 0.2], got {self.gain_sd!r}")
        if not (isinstance(self.offset_sd, (int, float)) and 0 <= self.offset_sd < np.inf):
            raise ConfigError(f"actuator_cells.offset_sd must be a finite force >= 0 in N, got {self.offset_sd!r}")
        gain, offset = _cell_values("gain", self.gain), _cell_values("offset", self.offset)
        if gain is not None and np.any(np.asarray(gain) <= -1):
            raise ConfigError(f"actuator_cells.gain must be > -1 for every cell, got {self.gain!r}")
        object.__setattr__(self, "gain", gain)
        object.__setattr__(self, "offset", offset)


#: Largest skew of a stream [s]: ten 10 Hz frames.
MAX_CLOCK_SKEW_S = 1.0


@dataclass(frozen=True)
class ClockSkew:
    """``clock_skew``: each stream sampled off its time stamp.

    Stream ``s`` logs at frame time ``t`` the signal of time ``t + skew_s`` (negative: an older
    sample), read from the noise-free signal by linear interpolation between frames
    (:func:`friction_models.shifted_read`; fractions of a frame allowed), and held at a
    trajectory's first and last frame beyond them.  In a continuous session the joints hold still
    for 0.5 s before each logged trajectory and for 1-5 s after it (the unlogged transition), so
    for skews up to 0.5 s the held value is close to what the robot did there; in a fresh
    session the hold is a convention.  The truth transmission and the truth columns
    keep the true time.  Each skew lies within ``±1`` s (ten 10 Hz frames).

    Parameters
    ----------
    angles_s : float
        Skew of the joint encoders [s]. Default 0.
    actuator_s : float
        Skew of the actuator-side load cells [s]. Default 0.
    terminal_s : float
        Skew of the terminal load cells [s]. Default -0.05, half a 10 Hz frame late: the paper
        synchronises its streams at 10 Hz (§IV-A), and the terminal cells, mounted at the joint
        for evaluation only (its Fig. 3(a)), are the stream most likely read by an acquisition
        of its own.  A stream aligned to the logging clock by its latest sample is between 0
        and one frame old, half a frame on average (a reasoned default, not a measured one).
    """

    angles_s: float = 0.0
    actuator_s: float = 0.0
    terminal_s: float = -0.05

    def __post_init__(self) -> None:
        for name in ("angles_s", "actuator_s", "terminal_s"):
            value = getattr(self, name)
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise ConfigError(f"clock_skew.{name} must be a time in s, got {value!r}") from None
            if not abs(value) <= MAX_CLOCK_SKEW_S:
                raise ConfigError(f"clock_skew.{name} must lie within ±{MAX_CLOCK_SKEW_S} s, got {value}")
            object.__setattr__(self, name, value)


@dataclass(frozen=True)
class LoadCellDynamics:
    """``load_cell_dynamics``: a first-order lag of every load cell (actuator-side and terminal).

    ``y[t] = a y[t-1] + (1 - a) T[t]``, ``a = exp(-dt / tau_s)``, the exact step of
    ``tau_s y' + y = T`` with the tension held over each frame (:func:`friction_models.first_order_lowpass`),
    started settled (``y = T``) on each trajectory's first frame (in a continuous session it
    follows a 0.5 s hold of the joints).

    Parameters
    ----------
    tau_s : float
        Time constant [s], ``> 0``. Default 0.1: the settling of a 24-bit bridge ADC of the
        kind that reads such cells, the HX711 (Avia Semiconductor, "HX711 24-Bit
        Analog-to-Digital Converter (ADC) for Weigh Scales", data sheet: output settling time
        400 ms at its 10 Hz data rate), as a first-order lag that settles to 2 % in 4 tau.
    order : {1, 2}
        1 (default): the first-order lag above. 2: two such stages in cascade, each ``tau_s / 2``
        (the same mean delay, ``tau_s``): the cell's amplifier filter followed by the converter's
        digital filter, a critically damped second-order response. The diagnosis's load-cell
        block is first order: this is the benchmark's case of the right family in another form.
    """

    tau_s: float = 0.1
    order: int = 1

    def __post_init__(self) -> None:
        if not (isinstance(self.tau_s, (int, float)) and 0 < self.tau_s < np.inf):
            raise ConfigError(f"load_cell_dynamics.tau_s must be a positive time in s, got {self.tau_s!r}")
        if self.order not in (1, 2):
            raise ConfigError(f"load_cell_dynamics.order must be 1 or 2, got {self.order!r}")


@dataclass(frozen=True)
class FrictionDrift:
    """``friction_drift``: each guide's friction runs in, then wears, with the distance slid through it.

    The capstan exponent at guide ``k`` is multiplied by
    ``w_k(t) = 1 - d (1 - exp(-s_k / L)) + c s_k`` (:func:`friction_models.run_in_wear_factor`),
    ``s_k`` the sliding distance through the guide since new (``prior_sliding_m`` plus the
    session's so far, :func:`tendon_id.sim.drift.drift_factors`).  The exponential run-in is the
    common form of a running-in curve (Blau, "On the nature of running-in", *Tribology
    International* 38 (2005) 1007-1012); the wear term is linear in the sliding distance like the
    worn volume (Archard, "Contact and rubbing of flat surfaces", *J. Appl. Phys.* 24 (1953)
    981-988).  The magnitudes are not measured on a snake: they are set so that the run-in is
    mostly done within a paper-sized session and the wear then shows.  For scale, with
    ``snake12-paper`` the paper's planned paths (10 000 frames) slide about 0.3-0.6 m through
    each guide, its terminal-only scans (50 000 frames) about 0.3 m through the first guide and
    3 m through the last.

    Parameters
    ----------
    run_in_drop : float
        Fractional fall of friction over the run-in, ``d`` in ``[0, 1)`` [-]. Default 0.2.
    run_in_length_m : float
        Run-in distance ``L`` [m], ``> 0``. Default 0.5.
    wear_rate_per_m : float
        Rise of the multiplier per metre slid, ``c >= 0`` [1/m]. Default 0.05.
    prior_sliding_m : float
        Distance slid through every guide before the session [m], ``>= 0``. Default 0 (new
        tendons and guides).
    form : {"exponential", "hyperbolic"}
        Shape of the run-in: ``"exponential"`` (default) as above; ``"hyperbolic"``,
        ``1 - d s / (s + L)``, which approaches the steady friction more slowly, another of the
        running-in curves Blau (2005) reviews. The diagnosis's drift block is exponential: this
        is the benchmark's case of the right family in another form.
    """

    run_in_drop: float = 0.2
    run_in_length_m: float = 0.5
    wear_rate_per_m: float = 0.05
    prior_sliding_m: float = 0.0
    form: str = "exponential"

    def __post_init__(self) -> None:
        if not (isinstance(self.run_in_drop, (int, float)) and 0 <= self.run_in_drop < 1):
            raise ConfigError(f"friction_drift.run_in_drop must lie in [0, 1), got {self.run_in_drop!r}")
        if not (isinstance(self.run_in_length_m, (int, float)) and 0 < self.run_in_length_m < np.inf):
            raise ConfigError(
                f"friction_drift.run_in_length_m must be a positive distance in m, got {self.run_in_length_m!r}"
            )
        if not (isinstance(self.wear_rate_per_m, (int, float)) and 0 <= self.wear_rate_per_m < np.inf):
            raise ConfigError(f"friction_drift.wear_rate_per_m must be >= 0 per m, got {self.wear_rate_per_m!r}")
        if not (isinstance(self.prior_sliding_m, (int, float)) and 0 <= self.prior_sliding_m < np.inf):
            raise ConfigError(
                f"friction_drift.prior_sliding_m must be a distance >= 0 in m, got {self.prior_sliding_m!r}"
            )
        if self.form not in ("exponential", "hyperbolic"):
            raise ConfigError(f"friction_drift.form must be 'exponential' or 'hyperbolic', got {self.form!r}")
