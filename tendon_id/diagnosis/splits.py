"""Training and held-out data of a diagnosis: one pair of a family's inputs per split."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from tendon_id.family.inputs import stacked

__all__ = ["Split"]


@dataclass(frozen=True)
class Split:
    """One training/held-out pair, as the arrays the family's models read (:meth:`~tendon_id.family.Family.splits`).

    Attributes
    ----------
    train, test : FrameInputs
        The family's inputs; ``train`` may be a :class:`~tendon_id.family.inputs.Stacked`,
        stacked only when read through :meth:`training`.
    noise : object, optional
        What the family knows of the sensors' noise on the held-out frames, for its noise floor
        (:meth:`~tendon_id.family.Family.noise_floor`); None where nothing is declared.
    """

    train: Any
    test: Any
    noise: Any = None

    def training(self):
        """The training inputs, stacked now if they are parts (hold them only while they are fitted)."""
        return stacked(self.train)
