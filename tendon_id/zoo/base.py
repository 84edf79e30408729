"""The estimator contract shared by every transmission hypothesis (scikit-learn conventions).

* ``__init__`` only stores settings; ``get_params``/``set_params`` read them back.
* ``fit(data)`` returns ``self``; fitted state ends in ``_``.
* ``predict(data)`` returns joint-side estimates ``T[j, j, i]``, shape (T, N, 3) [N],
  without side effects; ``predict_chain`` every ``T[k, j, i]``, shape (T, N, N, 3).
* ``save(dir)``: ``model.json`` plus ``arrays.npz`` (never pickle); :func:`tendon_id.zoo.load_model`
  reads it back.
"""

from __future__ import annotations

import abc
import inspect
import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from tendon_id.atomic import atomic_write, write_text_atomic
from tendon_id.data import Recording
from tendon_id.errors import ConfigError, TendonIdError
from tendon_id.metrics import tendon_metrics
from tendon_id.zoo.inputs import as_recordings

FORMAT_VERSION = 1


class NotFittedError(TendonIdError, RuntimeError):
    """A model was used before ``fit`` (or ``load``)."""


class TransmissionModel(abc.ABC):
    """Base class of the model zoo (see the module docstring)."""

    #: Registry name, e.g. ``"capstan-nonsmooth"``.
    name: ClassVar[str] = "base"

    # ---- parameters -------------------------------------------------------------
    @classmethod
    def param_names(cls) -> list[str]:
        """Names of the settings ``__init__`` takes (scikit-learn's ``_get_param_names``)."""
        sig = inspect.signature(cls.__init__)
        return [
            p for p in sig.parameters if p != "self" and sig.parameters[p].kind is not inspect.Parameter.VAR_KEYWORD
        ]

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """The settings given to ``__init__``."""
        return {p: getattr(self, p) for p in self.param_names()}

    def set_params(self, **params: Any) -> TransmissionModel:
        """Change settings; unknown names are an error. Returns ``self``."""
        known = set(self.param_names())
        for k, v in params.items():
            if k not in known:
                raise ConfigError(f"{self.name} has no setting {k!r}; settings: {', '.join(sorted(known))}")
            setattr(self, k, v)
        return self

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"

    # ---- fitting and prediction (each model implements fit and predict_chain) ------------
    @abc.abstractmethod
    def fit(self, data: Recording | Sequence[Recording]) -> TransmissionModel:
        """Fit on terminal-only labels; returns ``self``."""

    @abc.abstractmethod
    def predict_chain(self, data: Recording | Sequence[Recording]) -> np.ndarray:
        """Every ``T[k, j, i]`` [N], shape (T, N, N, 3), NaN where ``k > j``."""

    def predict(self, data: Recording | Sequence[Recording]) -> np.ndarray:
        """Joint-side estimates ``T[j, j, i]`` [N], shape (T, N, 3)."""
        chain = self.predict_chain(data)
        n = chain.shape[1]
        return chain[:, np.arange(n), np.arange(n)]

    def predict_terminal(self, data: Recording | Sequence[Recording]) -> np.ndarray:
        """What the terminal load cell is predicted to read [N], shape (T, 3)."""
        return self.predict(data)[:, -1]

    @property
    def is_fitted(self) -> bool:
        return bool(getattr(self, "n_modules_", None))

    def check_fitted(self) -> None:
        """Raise :class:`NotFittedError` unless the model is fitted (or loaded)."""
        if not self.is_fitted:
            raise NotFittedError(f"this {self.name} model is not fitted yet: call fit() or load() first")

    def _check_data(self, data) -> list[Recording]:
        recs = as_recordings(data)
        self.check_fitted()
        for r in recs:
            if r.n_modules != self.n_modules_:
                raise ConfigError(
                    f"the model was fitted on {self.n_modules_} modules but {r.source or 'the data'} has {r.n_modules}"
                )
        return recs

    def score(self, data: Recording | Sequence[Recording]) -> dict[str, Any]:
        """Metrics of DESIGN §8: ``{"terminal": M, "joints": {"overall": M, "per_joint": [M, ...]} | None}``.

        ``joints`` needs simulator truth: ``per_joint`` lists joints ``1..N`` and
        ``overall`` pools the intermediate joints ``2..N-1``.
        """
        recs = self._check_data(data)
        truth = [r.joint_truth for r in recs]
        terminal = np.concatenate([r.terminal for r in recs])
        out: dict[str, Any] = {"terminal": tendon_metrics(self.predict_terminal(recs), terminal), "joints": None}
        if all(t is not None for t in truth):
            joint_truth = np.concatenate(truth)
            pred = self.predict(recs)
            n = pred.shape[1]
            per_joint = [tendon_metrics(pred[:, j], joint_truth[:, j]) for j in range(n)]
            inner = slice(1, n - 1) if n > 2 else slice(0, 0)
            overall = (
                tendon_metrics(pred[:, inner].reshape(-1, 3), joint_truth[:, inner].reshape(-1, 3)) if n > 2 else None
            )
            out["joints"] = {"overall": overall, "per_joint": per_joint}
        return out

    # ---- persistence -------------------------------------------------------------
    @abc.abstractmethod
    def _state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """Fitted state as (JSON-able dict, arrays)."""

    @abc.abstractmethod
    def _restore(self, state: dict, arrays: dict[str, np.ndarray]) -> None:
        """Set the fitted state from :meth:`_state`'s output."""

    def _json_params(self) -> dict:
        return {k: _jsonable(v) for k, v in self.get_params().items()}

    def save(self, path: str | os.PathLike) -> Path:
        """Write ``path/model.json`` and ``path/arrays.npz`` (atomically each). Returns the folder."""
        self.check_fitted()
        folder = Path(path)
        folder.mkdir(parents=True, exist_ok=True)
        state, arrays = self._state()
        doc = {"format": FORMAT_VERSION, "model": self.name, "params": self._json_params(), "state": state}
        atomic_write(folder / "arrays.npz", lambda tmp: _savez(tmp, arrays))
        write_text_atomic(folder / "model.json", json.dumps(doc, indent=2, sort_keys=True) + "\n")
        return folder

    @classmethod
    def _from_params(cls, params: dict) -> TransmissionModel:
        return cls(**params)

    @classmethod
    def from_saved(cls, params: dict, state: dict, arrays: dict[str, np.ndarray]) -> TransmissionModel:
        """A fitted model from what :meth:`save` wrote: its settings, JSON state and arrays."""
        model = cls._from_params(params)
        model._restore(state, arrays)
        return model


def _savez(tmp: str, arrays: dict[str, np.ndarray]) -> None:
    with open(tmp, "wb") as fh:
        np.savez(fh, **{k: np.asarray(v) for k, v in arrays.items()})


def _jsonable(v: Any) -> Any:
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if hasattr(v, "to_dict"):
        return v.to_dict()
    if isinstance(v, np.generic):
        return v.item()
    return v
