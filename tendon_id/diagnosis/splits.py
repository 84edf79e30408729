"""Training and held-out data of a diagnosis: one pair of a family's inputs per split."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["Split"]


@dataclass(frozen=True)
class Split:
    """One training/held-out pair, as the arrays the family's models read (:meth:`~tendon_id.family.Family.splits`).

    Attributes
    ----------
    train, test : FrameInputs
        The family's inputs.
    noise : object, optional
        What the family knows of the sensors' noise on the held-out frames, for its noise floor
        (:meth:`~tendon_id.family.Family.noise_floor`); None where nothing is declared.
    """

    train: Any
    test: Any
    noise: Any = None
