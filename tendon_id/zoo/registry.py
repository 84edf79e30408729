"""The zoo's registry: ``make(name, **params)`` builds a model, ``names()`` lists them.

The built-in models are listed by where they live, not imported: a model's module is
imported the first time that model is asked for, so ``import tendon_id.zoo`` and the
analytic models never load torch (the neural ones need it).
"""

from __future__ import annotations

import importlib

from tendon_id.errors import ConfigError
from tendon_id.zoo.base import TransmissionModel

#: Built-in models: registry name -> ``"module:Class"``, in the order ``names()`` lists them.
BUILTIN: dict[str, str] = {
    "proximal": "tendon_id.zoo.proximal:ProximalModel",
    "capstan-simple": "tendon_id.zoo.capstan:CapstanSimple",
    "capstan-contact": "tendon_id.zoo.capstan:CapstanContact",
    "capstan-nonsmooth": "tendon_id.zoo.capstan:CapstanNonsmooth",
    "capstan-const-mu": "tendon_id.zoo.capstan:CapstanConstMu",
    "capstan": "tendon_id.zoo.capstan:CapstanModel",
    "mlp": "tendon_id.zoo.baselines:MLPBaseline",
    "lstm": "tendon_id.zoo.baselines:LSTMBaseline",
    "transformer": "tendon_id.zoo.baselines:TransformerBaseline",
    "pg-chtc": "tendon_id.zoo.learned:PGCHTC",
    "pg-chtc-ns": "tendon_id.zoo.learned_ns:PGCHTCNS",
    "passage-capstan": "tendon_id.zoo.passage.model:PassageCapstan",
}

_REGISTRY: dict[str, type[TransmissionModel] | str] = dict(BUILTIN)


def register(cls: type[TransmissionModel]) -> type[TransmissionModel]:
    """Add a model class under its ``name`` (usable as a decorator)."""
    _REGISTRY[cls.name] = cls
    return cls


def names() -> list[str]:
    """Registered model names, in registration order (imports no model)."""
    return list(_REGISTRY)


def names_of(family: type[TransmissionModel]) -> list[str]:
    """Registered names whose class is ``family`` or derives from it.

    Built-in models are only imported from ``family``'s own module (listing the capstan
    family does not load torch); classes registered with :func:`register` are all checked.
    """
    out = []
    for name in _REGISTRY:
        if name in BUILTIN and BUILTIN[name].partition(":")[0] != family.__module__:
            continue  # the same answer whether or not that module is loaded yet
        if issubclass(model_class(name), family):
            out.append(name)
    return out


def model_class(name: str) -> type[TransmissionModel]:
    """The class registered as ``name``, importing its module on first use."""
    if name not in _REGISTRY:
        raise ConfigError(f"unknown model {name!r}; known models: {', '.join(names())}")
    entry = _REGISTRY[name]
    if isinstance(entry, str):
        module, _, attr = entry.partition(":")
        entry = _REGISTRY[name] = getattr(importlib.import_module(module), attr)
    return entry


def make(name: str, **params) -> TransmissionModel:
    """Build an unfitted model; ``params`` are its settings (see its class)."""
    cls = model_class(name)
    known = cls.param_names()
    unknown = sorted(set(params) - set(known))
    if unknown:
        raise ConfigError(f"model {name!r} has no setting(s) {unknown}; its settings: {', '.join(known)}")
    return cls(**params)
