"""The snake chain's part of the diagnosis: its splits, strata, noise floor and signatures (:doc:`/guide/diagnosis`).

* **Splits**: a test set, or blocked cross-validation by trajectory; the session clock (which
  a sensor drift follows) runs over the files in order.
* **Strata**: one guide bent far, near tension reversals, bands of total wrap, joint speed,
  actuator tension, the session clock, and the first seconds of each log.
* **The noise floor** is simulated from the sensors the metadata declare (load-cell noise,
  encoder quantum), else taken from the residual's first differences.
* **The null data** that calibrate the paired test are simulated from the base's fit, read by
  the same sensors (:func:`simulate_null`).
* **Signatures**: each block's :meth:`~tendon_id.zoo.blocks.Block.signature`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from friction_models import play_operator
from tendon_id.data import Recording
from tendon_id.diagnosis.library import Library
from tendon_id.diagnosis.splits import Split
from tendon_id.diagnosis.stats import NoiseFloor, difference_floor
from tendon_id.diagnosis.where import quartile_masks
from tendon_id.errors import ConfigError
from tendon_id.sliding import backward_rate
from tendon_id.zoo.inputs import TransmissionInputs

__all__ = [
    "MeasurementNoise",
    "REVERSAL_BAND",
    "clean_estimates",
    "make_splits",
    "noise_floor",
    "read_sensors",
    "signatures",
    "simulate_null",
    "strata_masks",
]

#: Half-width of the log-tension band a tension must cross after a reversal to leave the
#: "near reversal" stratum [-] (5 %: a few times the stick band of one guide).
REVERSAL_BAND = 0.05


@dataclass(frozen=True)
class MeasurementNoise:
    """The sensors' noise the recordings' metadata declare (None where unknown).

    Attributes
    ----------
    load_cell : float or None
        Load-cell noise standard deviation [N].
    encoder_step : float or None
        Encoder quantum [rad] (``2 pi / 2**encoder_bits``).
    """

    load_cell: float | None = None
    encoder_step: float | None = None

    @classmethod
    def from_recordings(cls, recs: list[Recording]) -> MeasurementNoise:
        """The sensors' noise, where every recording declares the same."""

        def agreed(key: str):
            values = {(r.meta.get("sensors") or {}).get(key) for r in recs}
            v = values.pop() if len(values) == 1 else None
            return float(v) if v is not None else None

        bits = agreed("encoder_bits")
        return cls(agreed("noise_n"), 2.0 * np.pi / 2**bits if bits else None)


def make_splits(train: list[Recording], test: list[Recording] | None, geometry, folds: int) -> tuple[list[Split], str]:
    """The splits, and a description of the validation.

    The session clock (which a sensor drift follows) runs over the files in order, the
    test files after the training files.  Without ``test``, the trajectories of ``train``
    are cut into ``folds`` contiguous groups (blocked by trajectory, so no held-out frame
    has a training neighbour in time) and each group is held out once.

    Raises
    ------
    ConfigError
        When there are fewer trajectories than folds and no test data.
    """
    everything = TransmissionInputs.from_recordings(train + (test or []), geometry)
    n_train = sum(r.n_frames for r in train)
    if test is not None:
        is_train = np.arange(everything.n_frames) < n_train
        split = Split(everything.subset(is_train), everything.subset(~is_train), MeasurementNoise.from_recordings(test))
        return [split], "held-out test data"
    # Each frame's trajectory, numbered in session order (file by file, in order of first appearance).
    codes, n_ids = [], 0
    for r in train:
        c = r.trajectory_codes
        codes.append(c + n_ids)
        n_ids += int(c.max()) + 1 if c.size else 0
    traj = np.concatenate(codes)
    if n_ids < folds:
        raise ConfigError(
            f"cross-validation by trajectory needs at least {folds} trajectories, the training data has {n_ids}; "
            "give held-out test data or more trajectories",
            param="test",
        )
    noise = MeasurementNoise.from_recordings(train)
    splits = []
    for group in np.array_split(np.arange(n_ids), folds):
        held = (traj >= group[0]) & (traj <= group[-1])
        a, b = int(np.argmax(held)), len(held) - int(np.argmax(held[::-1]))
        if held[a:b].all():  # the group's frames in one run: parts of everything, views, no copies
            splits.append(Split(*everything.held_out(a, b), noise))
        else:  # a trajectory id that comes back later in its file
            splits.append(Split(everything.subset(~held), everything.subset(held), noise))
    return splits, f"{folds}-fold cross-validation by trajectory"


def strata_masks(inputs) -> list[tuple[str, str, NDArray]]:
    """``(name, kind, mask)`` of every stratum; masks have shape (T,) or (T, n).

    Parameters
    ----------
    inputs : TransmissionInputs
        The held-out data.
    """
    out: list[tuple[str, str, NDArray]] = []
    # The joints' part of the wrap, what the data show: a routing wrap, fitted or not, only shifts it.
    wrap = inputs.bend_wrap  # (T, K)
    for k in range(wrap.shape[1]):
        w = wrap[:, k]
        top = np.quantile(w, 0.75)
        if np.ptp(w) > 1e-3 and (w > top).any():
            out.append((f"guide {k + 1} bent (wrap > {top:.3f} rad)", "guide", w > top))
    # Near reversals: a play operator on the actuator tension sticks (sigma = 0) from a
    # reversal until the tension has moved 2 * REVERSAL_BAND in log away from it.
    act = inputs.actuator[:, -1]  # (T, n): the terminal set, the one the labels see
    stuck = play_operator(np.log(act), REVERSAL_BAND, inputs.reset).sigma == 0
    out.append(("near tension reversals", "reversal", stuck))
    out.append(("away from tension reversals", "reversal", ~stuck))
    for name, mask in quartile_masks(wrap.sum(axis=1), "total wrap", "rad"):
        out.append((name, "wrap", mask))
    speed = np.abs(backward_rate(inputs.angles, inputs.reset, inputs.dt)).max(axis=(1, 2))
    rest = "joints at rest" if speed.min() == 0 else None
    for name, mask in quartile_masks(speed, "joint speed", "deg/s", np.degrees(1.0), least=rest):
        out.append((name, "speed", mask))
    for name, mask in quartile_masks(act, "actuator tension", "N"):
        out.append((name, "tension", mask))
    for name, mask in quartile_masks(inputs.clock, "session clock", "s"):
        out.append((name, "time", mask))
    # The first seconds of each log: a model that guesses the stick/slip and lag state at a
    # log's start is wrong there until the state is forgotten.
    for name, mask in quartile_masks(inputs.since_start, "time since log start", "s"):
        out.append((name, "start", mask))
    return out


def signatures(structure, fitted, inputs: TransmissionInputs, blocks: dict) -> Library:
    """The signatures of ``blocks`` (``{effect: Block}``) added to ``structure``, with ``fitted``'s law on ``inputs``.

    The law is ``fitted``'s, the other blocks' values ``structure``'s (the base's fit).
    """
    A, B, values = fitted.A_, fitted.B_, structure.block_params_
    labels, effects, cols = [], [], []
    reading = structure.terminal_reading(inputs, A, B, values)
    for effect, block in blocks.items():
        for label, col in block.signature(structure, inputs, A, B, values, reading).items():
            labels.append(label)
            effects.append(effect)
            cols.append(col)
    columns = np.stack(cols, axis=-1) if cols else np.zeros(inputs.terminal.shape + (0,))
    return Library(labels, effects, columns)


def _smooth(x: NDArray, inputs, width: int, *, median: bool = False) -> NDArray:
    """Moving average (or running median) of ``width`` frames along time, within each trajectory.

    The running median (Tukey 1977) keeps the steps of a step-and-hold protocol sharp,
    where a moving average would ramp through them; on a monotone ramp both return it.
    """
    from scipy.ndimage import median_filter, uniform_filter1d

    out = x.copy()
    for a, b in inputs.trajectory_bounds:
        if median:
            out[a:b] = median_filter(x[a:b], size=(width,) + (1,) * (x.ndim - 1), mode="nearest")
        else:
            out[a:b] = uniform_filter1d(x[a:b], size=width, axis=0, mode="nearest")
    return out


def clean_estimates(sensors: MeasurementNoise, inputs):
    """Estimates of the clean inputs behind measured ones: the actuator cells' running median over 1 s,
    the angles' average over 3 frames where an encoder quantum is declared, within each trajectory."""
    actuator = _smooth(inputs.actuator, inputs, max(int(round(1.0 / inputs.dt)) | 1, 3), median=True)
    angles = _smooth(inputs.angles, inputs, 3) if sensors.encoder_step else inputs.angles
    return dataclasses.replace(inputs, actuator=actuator, angles=angles)


def read_sensors(sensors: MeasurementNoise, clean, rng):
    """``clean`` inputs as the declared sensors read them: cell noise, and encoder readings at a random offset.

    A quantum is a function of the true angle (:class:`~tendon_id.sim.Sensors`); the offset stands
    for where the clean estimate sits on the true grid, which is unknown.
    """
    sigma, step = sensors.load_cell, sensors.encoder_step
    actuator = np.maximum(clean.actuator + sigma * rng.standard_normal(clean.actuator.shape), 1e-3)
    angles = clean.angles
    if step:
        offset = rng.uniform(0.0, step, size=angles.shape[1:])
        angles = np.round((angles + offset) / step) * step - offset
    return dataclasses.replace(clean, actuator=actuator, angles=angles)


def simulate_null(sensors: MeasurementNoise | None, model, split: Split, rng, draws: int = 1) -> list[Split] | None:
    """``draws`` splits simulated from ``model``: its clean reading of the split's clean estimates, read by the sensors.

    The data a diagnosis would see if the fitted ``model`` were the truth (a parametric bootstrap,
    Efron & Tibshirani 1993, ch. 6): the clean inputs are estimated (:func:`clean_estimates`), the
    terminal label is ``model``'s reading of them plus the cell noise, and the inputs are read by
    the sensors (:func:`read_sensors`); the clean part is computed once for all draws.  None
    without a declared load-cell noise.
    """
    if sensors is None or sensors.load_cell is None or not sensors.load_cell > 0:
        return None
    law = (model.A_, model.B_, model.block_params_)
    parts = []
    for inputs in (split.training(), split.test):
        clean = clean_estimates(sensors, inputs)
        parts.append((clean, model.terminal_reading(clean, *law)))

    def read(clean, label):
        label = np.maximum(label + sensors.load_cell * rng.standard_normal(label.shape), 1e-3)
        return dataclasses.replace(read_sensors(sensors, clean, rng), terminal=label)

    return [Split(*(read(*part) for part in parts), sensors) for _ in range(draws)]


def noise_floor(
    sensors: MeasurementNoise | None, model, inputs, residual: NDArray, rng, *, draws: int = 20, level: float = 0.95
) -> NoiseFloor:
    """The held-out error of a perfect model on these frames, by simulating the sensors.

    A model is fed measured inputs, so even the true one errs by more than the terminal
    cell's noise ``sigma``.  A play operator does not pass input errors like a ratio does:
    a noise spike or an encoder step that moves a stick band edge past the tension drags
    the output along and it stays there (a ratchet), so the inherited error is heavy-tailed
    and varies much from one realisation to the next.  It is therefore simulated: from
    estimates of the clean signals (the actuator cells' running median over 1 s, the angles'
    average over 3 frames, within each trajectory) each of ``draws`` draws adds ``sigma`` of cell noise
    and re-reads the angles on the encoder grid at a random offset (a quantum is a function
    of the true angle, :class:`~tendon_id.sim.Sensors`), and the model's prediction is
    compared with its prediction from the clean estimates.  A draw's mean squared error is
    ``sigma^2 + mean(dT^2)``; ``rmse`` is the root of their mean, ``upper`` of their
    ``level`` quantile.  (On ``snake12-noise-only`` with a nonsmooth capstan, the true
    law's inherited error was 1.0–1.8 N over ten realisations, and the draws spread over
    0.9–1.7 N: one realisation is compared with the quantile, not the mean.)

    Without a load-cell noise in the metadata, the floor comes from the residual's first
    differences (von Neumann 1941): a model error that varies slowly next to the noise
    cancels in them, so ``floor = std(diff(e)) / sqrt(2)``; it has no spread (``upper = rmse``).

    Parameters
    ----------
    sensors : MeasurementNoise
        Load-cell noise [N] and encoder quantum [rad] from the metadata.
    model : CapstanModel
        Fitted base model.
    inputs : TransmissionInputs
        Held-out frames.
    residual : ndarray, shape (T, n)
        The base's held-out residual [N].
    rng : numpy.random.Generator
    draws : int
        Simulated measurement draws.
    level : float
        Quantile of ``upper``.
    """
    sigma = sensors.load_cell if sensors is not None else None
    if sigma is None or not sigma > 0:
        return difference_floor(residual)
    clean_inputs = clean_estimates(sensors, inputs)
    law = (model.A_, model.B_, model.block_params_)
    clean = model.terminal_reading(clean_inputs, *law)
    mse = np.empty(draws)
    for k in range(draws):
        shaken = model.terminal_reading(read_sensors(sensors, clean_inputs, rng), *law)
        mse[k] = sigma**2 + np.mean((shaken - clean) ** 2)
    source = "metadata (load-cell noise" + (", encoder quantum)" if sensors.encoder_step else ")")
    return NoiseFloor(float(np.sqrt(mse.mean())), float(np.sqrt(np.quantile(mse, level))), source)
