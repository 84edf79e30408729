"""Training and held-out data of a diagnosis: a test set, or blocked cross-validation by trajectory."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from tendon_id.data import Recording
from tendon_id.errors import ConfigError
from tendon_id.zoo.inputs import TransmissionInputs


@dataclass(frozen=True)
class Split:
    """One training/held-out pair, as the arrays the models read."""

    train: TransmissionInputs
    test: TransmissionInputs
    noise: MeasurementNoise


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


#: The per-frame arrays of :class:`TransmissionInputs` (the rest is shared by all frames).
FRAME_FIELDS = ("angles", "actuator", "terminal", "reset", "clock")


def subset(inputs: TransmissionInputs, mask: np.ndarray) -> TransmissionInputs:
    """The frames of whole trajectories in ``mask``, keeping their session clock."""
    return dataclasses.replace(inputs, **{f: getattr(inputs, f)[mask] for f in FRAME_FIELDS})


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
        split = Split(
            subset(everything, is_train), subset(everything, ~is_train), MeasurementNoise.from_recordings(test)
        )
        return [split], "held-out test data"
    traj = np.concatenate([np.char.add(f"{k}/", r.trajectory_ids.astype(str)) for k, r in enumerate(train)])
    _, first = np.unique(traj, return_index=True)
    ids = traj[np.sort(first)]  # trajectories in session order
    if len(ids) < folds:
        raise ConfigError(
            f"cross-validation by trajectory needs at least {folds} trajectories, the training data has {len(ids)}; "
            "pass held-out test data (--test) or more trajectories"
        )
    noise = MeasurementNoise.from_recordings(train)
    splits = []
    for group in np.array_split(ids, folds):
        held = np.isin(traj, group)
        splits.append(Split(subset(everything, ~held), subset(everything, held), noise))
    return splits, f"{folds}-fold cross-validation by trajectory"


def stack(parts: list[TransmissionInputs]) -> TransmissionInputs:
    """The held-out frames of every split, one after the other (clocks kept)."""
    if len(parts) == 1:
        return parts[0]
    return dataclasses.replace(parts[0], **{f: np.concatenate([getattr(p, f) for p in parts]) for f in FRAME_FIELDS})
