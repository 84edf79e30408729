"""The model zoo: every transmission hypothesis behind one ``fit``/``predict`` interface (:doc:`/guide/zoo`).

>>> from tendon_id import zoo
>>> model = zoo.make("capstan-nonsmooth", tying="tied")    # doctest: +SKIP
>>> model.fit(train).predict(test).shape                    # doctest: +SKIP
(T, N, 3)

Importing the zoo loads no neural model: the registry imports a model's module (and torch,
for the learned ones) only when that model is made or loaded.
"""

from tendon_id.zoo.base import NotFittedError, TransmissionModel
from tendon_id.zoo.blocks import (
    ActuatorCells,
    BendingStiffness,
    Block,
    ClockSkew,
    ContactGate,
    ElasticTendon,
    FrictionDrift,
    GuideWear,
    Hysteresis,
    LoadCellDynamics,
    PerTendonWrap,
    RoutingWrap,
    SensorBias,
    SmoothEdge,
    StartState,
    VelocityFriction,
    ViscoelasticLag,
)
from tendon_id.zoo.capstan import CapstanModel
from tendon_id.zoo.inputs import TransmissionInputs
from tendon_id.zoo.persistence import load
from tendon_id.zoo.proximal import ProximalModel
from tendon_id.zoo.registry import make, model_class, names, names_of, register, unregister

__all__ = [
    "ActuatorCells",
    "BendingStiffness",
    "Block",
    "CapstanModel",
    "ClockSkew",
    "ContactGate",
    "ElasticTendon",
    "FrictionDrift",
    "GuideWear",
    "Hysteresis",
    "LoadCellDynamics",
    "NotFittedError",
    "PerTendonWrap",
    "ProximalModel",
    "RoutingWrap",
    "SensorBias",
    "SmoothEdge",
    "StartState",
    "TransmissionInputs",
    "TransmissionModel",
    "VelocityFriction",
    "ViscoelasticLag",
    "load",
    "make",
    "model_class",
    "names",
    "names_of",
    "register",
    "unregister",
]
