"""The estimator contract of every model (scikit-learn conventions), whatever data it reads.

* ``__init__`` only stores settings; ``get_params``/``set_params`` read them back.
* ``fit(data)`` returns ``self``; fitted state ends in ``_``; ``predict`` has no side effects.
* ``save(dir)``: ``model.json`` plus ``arrays.npz`` (never pickle); :func:`tendon_id.zoo.load`
  reads it back.

:class:`~tendon_id.zoo.base.TransmissionModel` (a snake's tendons) and
:class:`~tendon_id.zoo.passage.PassageModel` (one passage on a bench) derive from it.
"""

from __future__ import annotations

import abc
import hashlib
import inspect
import io
import os
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from tendon_id.atomic import atomic_write_all, json_text, write_group
from tendon_id.checks import check_finite_result, check_keys
from tendon_id.errors import TendonIdError
from tendon_id.zoo.arrays_file import members_record

FORMAT_VERSION = 1
#: The arrays' file of a model folder, and the key of ``model.json`` that records its digest.
ARRAYS_FILE = "arrays.npz"
ARRAYS_KEY = "arrays"


class NotFittedError(TendonIdError, RuntimeError):
    """A model was used before ``fit`` (or ``load``)."""


class Estimator(abc.ABC):
    """Settings, fitted-state checks and persistence shared by every model."""

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

    def set_params(self, **params: Any) -> Estimator:
        """Change settings; unknown names are an error. Returns ``self``."""
        check_keys(params, self.param_names(), what=f"setting of {self.name}")
        for k, v in params.items():
            setattr(self, k, v)
        return self

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"

    def check_settings(self) -> None:
        """Raise ConfigError for settings that cannot work, before any data is read (default: nothing to check)."""

    @property
    @abc.abstractmethod
    def is_fitted(self) -> bool:
        """Whether ``fit`` (or ``load``) has set the fitted state."""

    def check_fitted(self) -> None:
        """Raise :class:`NotFittedError` unless the model is fitted (or loaded)."""
        if not self.is_fitted:
            raise NotFittedError(f"this {self.name} model is not fitted yet: call fit() or load() first")

    # ---- persistence -------------------------------------------------------------
    @abc.abstractmethod
    def _state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """Fitted state as (JSON-able dict, arrays)."""

    @abc.abstractmethod
    def _restore(self, state: dict, arrays: dict[str, np.ndarray]) -> None:
        """Set the fitted state from :meth:`_state`'s output."""

    def check_finite_fit(self, inputs: str = "its data") -> None:
        """Raise :class:`~tendon_id.errors.NonFiniteResult` where a fitted array is NaN or inf.

        A fit that diverged is an error naming ``inputs`` (the files it was fitted on), never a model.
        """
        self.check_fitted()
        _check_finite_state(self.name, *self._state(), inputs)

    def _json_params(self) -> dict:
        return {k: _jsonable(v) for k, v in self.get_params().items()}

    def save(self, path: str | os.PathLike) -> Path:
        """Write ``path/model.json`` and ``path/arrays.npz`` as one unit. Returns the folder.

        Each file is written atomically; ``model.json`` records the SHA-256 of ``arrays.npz``,
        which :func:`~tendon_id.zoo.load` checks, so a folder mixed from two saves (or a save cut
        off between its files) is refused, never loaded. The pair is written under
        :func:`~tendon_id.atomic.write_group`: one writer at a time per folder, no interrupt between.
        """
        self.check_fitted()
        folder = Path(path)
        state, arrays = self._state()
        _check_finite_state(self.name, state, arrays, "its data")  # a diverged fit is never saved
        buf = io.BytesIO()
        np.savez(buf, **{k: np.asarray(v) for k, v in arrays.items()})
        blob = buf.getvalue()
        doc = {
            "format": FORMAT_VERSION,
            "model": self.name,
            "params": self._json_params(),
            "state": state,
            ARRAYS_KEY: {
                "file": ARRAYS_FILE,
                "sha256": hashlib.sha256(blob).hexdigest(),
                "bytes": len(blob),
                "members": members_record(arrays),  # what load reads, and the sizes it checks first
            },
        }
        text = json_text(doc, sort_keys=True) + "\n"  # standard JSON: an undefined value is null
        new_folder = not folder.exists()
        try:
            with write_group(folder):  # both files written, then both renamed: a full disk replaces neither
                atomic_write_all(
                    [
                        (folder / ARRAYS_FILE, lambda tmp: _write_blob(tmp, blob)),
                        (folder / "model.json", lambda tmp: Path(tmp).write_text(text, encoding="utf-8")),
                    ]
                )
        except BaseException:
            if new_folder and folder.is_dir() and not any(folder.iterdir()):
                folder.rmdir()  # the folder this save made, and nothing in it
            raise
        return folder

    @classmethod
    def _from_params(cls, params: dict) -> Estimator:
        return cls(**params)

    @classmethod
    def from_saved(cls, params: dict, state: dict, arrays: dict[str, np.ndarray]) -> Estimator:
        """A fitted model from what :meth:`save` wrote: its settings, JSON state and arrays."""
        model = cls._from_params(params)
        model._restore(state, arrays)
        return model


#: Entries of a fitted state that report on the fit rather than define the model: a NaN there is
#: an undefined figure (a loss that never ran, a correlation of a fixed parameter), not a result.
_REPORTS = ("history", "calibration", "guard", "r2")


def _check_finite_state(name: str, state: dict, arrays: dict, inputs: str) -> None:
    fitted = {"state": state, "arrays": {k: np.asarray(v) for k, v in arrays.items()}}
    check_finite_result(fitted, what=f"fitting {name}", inputs=inputs, undefined=_REPORTS)


def _write_blob(tmp: str, blob: bytes) -> None:
    """Write the arrays' bytes to the temporary file (one function, so tests can cut it off)."""
    Path(tmp).write_bytes(blob)


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
