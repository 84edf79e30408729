"""The zoo's registry: ``make(name, **params)`` builds a model, ``names()`` lists them."""

from __future__ import annotations

from tendon_id.errors import ConfigError
from tendon_id.zoo.base import TransmissionModel
from tendon_id.zoo.baselines import LSTMBaseline, MLPBaseline, TransformerBaseline
from tendon_id.zoo.capstan import CapstanConstMu, CapstanContact, CapstanModel, CapstanNonsmooth, CapstanSimple, ProximalModel
from tendon_id.zoo.learned import PGCHTC

_REGISTRY: dict[str, type[TransmissionModel]] = {}


def register(cls: type[TransmissionModel]) -> type[TransmissionModel]:
    """Add a model class under its ``name`` (usable as a decorator)."""
    _REGISTRY[cls.name] = cls
    return cls


for _cls in (ProximalModel, CapstanSimple, CapstanContact, CapstanNonsmooth, CapstanConstMu, CapstanModel, MLPBaseline, LSTMBaseline,
             TransformerBaseline, PGCHTC):
    register(_cls)


def names() -> list[str]:
    """Registered model names, in registration order."""
    return list(_REGISTRY)


def model_class(name: str) -> type[TransmissionModel]:
    """The class registered as ``name``."""
    if name not in _REGISTRY:
        raise ConfigError(f"unknown model {name!r}; known models: {', '.join(names())}")
    return _REGISTRY[name]


def make(name: str, **params) -> TransmissionModel:
    """Build an unfitted model; ``params`` are its settings (see its class)."""
    cls = model_class(name)
    known = cls._param_names()
    unknown = sorted(set(params) - set(known))
    if unknown:
        raise ConfigError(f"model {name!r} has no setting(s) {unknown}; its settings: {', '.join(known)}")
    return cls(**params)
