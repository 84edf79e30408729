"""The model zoo: every transmission hypothesis behind one ``fit``/``predict`` interface (DESIGN §6).

>>> from tendon_id import zoo
>>> model = zoo.make("capstan-nonsmooth", tying="tied")    # doctest: +SKIP
>>> model.fit(train).predict(test).shape                    # doctest: +SKIP
(T, N, 3)
"""

from tendon_id.zoo.base import NotFittedError, TransmissionModel, load_model
from tendon_id.zoo.blocks import Block, ContactGate, Hysteresis, SensorBias, ViscoelasticLag
from tendon_id.zoo.capstan import CapstanModel, ProximalModel
from tendon_id.zoo.inputs import TransmissionInputs
from tendon_id.zoo.registry import make, model_class, names, register

load = load_model

__all__ = [
    "Block",
    "CapstanModel",
    "ContactGate",
    "Hysteresis",
    "NotFittedError",
    "ProximalModel",
    "SensorBias",
    "TransmissionInputs",
    "TransmissionModel",
    "ViscoelasticLag",
    "load",
    "load_model",
    "make",
    "model_class",
    "names",
    "register",
]
