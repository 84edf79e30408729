"""The zoo's registry: ``make(name, **params)`` builds a model, ``names()`` lists them.

The built-in models are listed by where they live, not imported: a model's module is
imported the first time that model is asked for, so ``import tendon_id.zoo`` and the
analytic models never load torch (the neural ones need it).
"""

from __future__ import annotations

from tendon_id.errors import ConfigError
from tendon_id.registry import Registry
from tendon_id.zoo.estimator import Estimator

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

_MODELS = Registry("model", BUILTIN)


def register(cls: type[Estimator]) -> type[Estimator]:
    """Add a model class under its ``name`` (usable as a decorator)."""
    return _MODELS.register(cls.name, cls)


def unregister(name: str) -> None:
    """Remove the model registered as ``name`` (a built-in one comes back as it was)."""
    _MODELS.unregister(name)


def names() -> list[str]:
    """Registered model names, in registration order (imports no model)."""
    return _MODELS.names()


def names_of(family: type[Estimator]) -> list[str]:
    """Registered names whose class is ``family`` or derives from it.

    Built-in models are only imported from ``family``'s own module (listing the capstan
    models does not load torch); classes registered with :func:`register` are all checked.
    """
    out = []
    for name in _MODELS.names():
        module = _MODELS.builtin_module(name)
        if module is not None and module != family.__module__:
            continue  # the same answer whether or not that module is loaded yet
        if issubclass(model_class(name), family):
            out.append(name)
    return out


def model_class(name: str) -> type[Estimator]:
    """The class registered as ``name``, importing its module on first use."""
    return _MODELS.get(name, "model")


def make(name: str, **params) -> Estimator:
    """Build an unfitted model; ``params`` are its settings (see its class).

    Raises
    ------
    ConfigError
        For an unknown model, or a setting it does not have (naming that setting as the parameter).
    """
    cls = model_class(name)
    known = cls.param_names()
    unknown = sorted(set(params) - set(known))
    if unknown:
        raise ConfigError(f"no setting of model {name!r}; its settings: {', '.join(known)}", param=unknown[0])
    return cls(**params)
