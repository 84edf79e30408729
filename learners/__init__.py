"""Torch modules and training loops of PG-CHTC (paper Section III-C/D, IV-B; :doc:`/guide/pgchtc`).

Imports flow one way: ``tendon_id -> learners -> friction_models``.  Everything here
works on tensors and arrays handed in by the caller, never on recordings or files.
"""

from learners.cascade import Cascade, CascadeInputs
from learners.presets import PRESETS, TrainConfig, UnitConfig, preset
from learners.unit import PGCHTMUnit, StaticBackbone, TemporalResidual

__all__ = [
    "PRESETS",
    "Cascade",
    "CascadeInputs",
    "PGCHTMUnit",
    "StaticBackbone",
    "TemporalResidual",
    "TrainConfig",
    "UnitConfig",
    "preset",
]
