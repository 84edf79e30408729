"""Withheld-effect cases whose truth is not any candidate block's form: another form of a family, or no family.

A real effect rarely has exactly a block's functional form. **Other-form** cases withhold an
effect of a family the library has, in a form its block does not take; the diagnosis should name
the family, say how much of the gap it closes and that the form differs, and not answer
"unexplained". **Out-of-library** cases withhold physics no family covers; the diagnosis should
not pass a candidate off as it.

Other forms (each at default magnitude scaled like the family's own cases):

* ``sensor_bias~warm_up``: the terminal cell's zero drifts as the bridge warms up,
  ``drift t_w (1 - exp(-t / t_w))``, where the block's drift is linear (``sensor_bias.drift_form``;
  initial rate :data:`WARM_UP_RATE`).
* ``load_cell_dynamics~second_order``: every cell a critically damped second-order lag, where the
  block's is first order (``load_cell_dynamics.order = 2``).
* ``friction_drift~hyperbolic``: a run-in ``s / (s + L)``, where the block's is exponential
  (``friction_drift.form``).
* ``velocity_friction~stribeck``: friction that dips from static to kinetic with speed (a Stribeck
  curve), where the block's grows linearly with sliding speed.
* ``clock_skew~transport_delay``: the terminal reading a whole number of frames late and held at
  each log's start, where the block shifts by fractions of a frame with interpolation.

Out of library:

* ``encoder_backlash``: each joint's encoder reads its joint through a gear with play, a
  backlash (play operator) of half-width :data:`BACKLASH_RAD` on the logged angles.
* ``cell_interference``: a periodic disturbance on the terminal cells (a pump's or a fan's),
  amplitude :data:`INTERFERENCE_N` at :data:`INTERFERENCE_HZ`.
"""

from __future__ import annotations

import numpy as np

from friction_models.play_operator import play_output
from tendon_id.data import Recording

#: Each other-form case and the family (the simulator effect) it belongs to.
OTHER_FORMS = {
    "sensor_bias~warm_up": "sensor_bias",
    "load_cell_dynamics~second_order": "load_cell_dynamics",
    "friction_drift~hyperbolic": "friction_drift",
    "velocity_friction~stribeck": "velocity_friction",
    "clock_skew~transport_delay": "clock_skew",
}
#: Out-of-library effects (no candidate block's family covers them).
OUT_OF_LIBRARY = ("encoder_backlash", "cell_interference")
#: Transport delay of the terminal load cell's reading at default magnitude [s].
SENSOR_DELAY_S = 0.4
#: Stribeck dip of mu from static to kinetic friction at default magnitude [-], and its speed [m/s].
STRIBECK_DROP = 0.25
STRIBECK_SPEED = 0.002
#: Initial rate of the warm-up drift at default magnitude [N/s]: with the 120 s warm-up it settles
#: 2.4 N from its start, half a percent of a 500 N cell's range (the linear default, 0.002 N/s,
#: moves 0.4 N over a case's test run, too little to show a form).
WARM_UP_RATE = 0.02
#: Half-width of an encoder gear's backlash at default magnitude [rad] (0.3 deg).
BACKLASH_RAD = np.radians(0.3)
#: Amplitude [N] and frequency [Hz] of the periodic disturbance at default magnitude.
INTERFERENCE_N = 3.0
INTERFERENCE_HZ = 0.37


def family_of(name: str) -> str:
    """The library family an other-form case belongs to, or the name itself."""
    return OTHER_FORMS.get(name, name)


def form_settings(name: str, scale: float, defaults) -> tuple[tuple[str, ...], dict]:
    """The effects to switch on and their settings for an other-form case at ``scale`` times its magnitude.

    ``defaults`` is :class:`tendon_id.sim.Effects` with every effect at its documented setting.
    Out-of-library cases and post-processed forms switch nothing on.
    """
    if name == "sensor_bias~warm_up":
        p = defaults.get("sensor_bias")
        return ("sensor_bias",), {
            "sensor_bias": {"offset": p.offset * scale, "gain": p.gain * scale, "drift": WARM_UP_RATE * scale}
            | {"drift_form": "warm_up"}
        }
    if name == "load_cell_dynamics~second_order":
        return ("load_cell_dynamics",), {
            "load_cell_dynamics": {"tau_s": defaults.get("load_cell_dynamics").tau_s * scale, "order": 2}
        }
    if name == "friction_drift~hyperbolic":
        p = defaults.get("friction_drift")
        return ("friction_drift",), {
            "friction_drift": {
                "run_in_drop": p.run_in_drop * scale,
                "wear_rate_per_m": p.wear_rate_per_m * scale,
                "form": "hyperbolic",
            }
        }
    if name == "velocity_friction~stribeck":
        drop = STRIBECK_DROP * scale
        return ("velocity_friction",), {
            "velocity_friction": {"v_ref": 1e6, "stribeck_drop": drop, "v_stribeck": STRIBECK_SPEED}
        }
    return (), {}


def post_process(rec: Recording, name: str, scale: float) -> Recording:
    """The recording as the sensors of a post-processed case log it (others unchanged)."""
    if name == "clock_skew~transport_delay":
        return _replaced(rec, terminal=_delayed(rec, SENSOR_DELAY_S * scale))
    if name == "encoder_backlash":
        return _replaced(rec, angles=_backlash(rec, BACKLASH_RAD * scale))
    if name == "cell_interference":
        wave = INTERFERENCE_N * scale * np.sin(2.0 * np.pi * INTERFERENCE_HZ * rec.time + 0.7)
        return _replaced(rec, terminal=rec.terminal + wave[:, None])
    return rec


def _replaced(rec: Recording, **arrays) -> Recording:
    d = {"angles": rec.angles, "actuator": rec.actuator, "terminal": rec.terminal, **arrays}
    return Recording.from_arrays(trajectory=rec.trajectory_ids, t=rec.time, joint_truth=None, meta=rec.meta, **d)


def _delayed(rec: Recording, delay_s: float) -> np.ndarray:
    """The terminal reading ``delay_s`` late, held at its first value at each trajectory start [N]."""
    lag = int(round(delay_s * rec.sample_rate_hz))
    terminal = rec.terminal.copy()
    starts = np.flatnonzero(rec.trajectory_starts).tolist() + [rec.n_frames]
    for a, b in zip(starts[:-1], starts[1:]):
        seg = rec.terminal[a:b]
        terminal[a:b] = np.concatenate([np.repeat(seg[:1], min(lag, b - a), axis=0), seg[: max(b - a - lag, 0)]])
    return terminal


def _backlash(rec: Recording, half_width: float) -> np.ndarray:
    """The logged angles read through a play of ``half_width`` [rad] per joint axis, restarting centred per log."""
    x = rec.angles.reshape(rec.n_frames, -1)
    starts = rec.trajectory_starts[:, None]
    # A restart reads the angle itself (the gear centred): a band of zero width on that frame.
    lo, hi = np.where(starts, x, x - half_width), np.where(starts, x, x + half_width)
    return play_output(lo, hi, rec.trajectory_starts).reshape(rec.angles.shape)
