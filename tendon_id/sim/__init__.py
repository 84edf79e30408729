"""The transmission simulator: the ground truth the toolkit is measured against (:doc:`/guide/simulator`).

It is physics (the capstan law of paper Eqs. (4)–(6) with switchable
unmodelled effects), never a curve chosen to flatter a model.
"""

from tendon_id.sim.actuation import Actuation
from tendon_id.sim.effects import EFFECT_NAMES, EFFECT_OPTIONS, EFFECT_TYPES, Effects, parse_effect_names
from tendon_id.sim.protocols import PAPER_FRAMES, PROTOCOL_NAMES, ProtocolSettings
from tendon_id.sim.recipe import Recipe
from tendon_id.sim.sensors import Sensors
from tendon_id.sim.simulate import Session, SimulationResult, simulate
from tendon_id.sim.transmission import FrictionLaw, TransmissionResult, transmit

__all__ = [
    "EFFECT_NAMES",
    "EFFECT_OPTIONS",
    "EFFECT_TYPES",
    "PAPER_FRAMES",
    "PROTOCOL_NAMES",
    "Actuation",
    "Effects",
    "FrictionLaw",
    "ProtocolSettings",
    "Recipe",
    "Sensors",
    "Session",
    "SimulationResult",
    "TransmissionResult",
    "parse_effect_names",
    "simulate",
    "transmit",
]
