"""Reading a saved model back: ``model.json`` names the model, the registry gives its class."""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import numpy as np

from tendon_id.errors import ConfigError
from tendon_id.zoo.estimator import FORMAT_VERSION, Estimator
from tendon_id.zoo.registry import model_class


def load(path: str | os.PathLike) -> Estimator:
    """Load a model saved by :meth:`~tendon_id.zoo.estimator.Estimator.save` (``tendon-id fit``).

    Only the saved model's own module is imported (a capstan model loads without torch).

    Raises
    ------
    ConfigError
        Naming the file, if the folder holds no model, an unknown one, or files that are not
        what ``save`` writes: truncated or foreign JSON, an ``arrays.npz`` that is not a zip of
        plain arrays (a pickle, object arrays: never loaded), or arrays the model cannot take.
    """
    folder = Path(path)
    doc_path = folder / "model.json"
    if not doc_path.is_file():
        raise ConfigError(f"{folder}: no model.json here; is this a folder written by 'tendon-id fit'?")
    try:
        doc = json.loads(doc_path.read_text())
    except json.JSONDecodeError as exc:
        raise ConfigError(f"{doc_path}: not valid JSON ({exc})") from None
    if doc.get("format") != FORMAT_VERSION:
        raise ConfigError(f"{doc_path}: unsupported model format {doc.get('format')!r}")
    cls = model_class(doc.get("model", ""))
    arrays_path = folder / "arrays.npz"
    arrays = _read_arrays(arrays_path) if arrays_path.is_file() else {}
    try:
        return cls.from_saved(doc.get("params", {}), doc.get("state", {}), arrays)
    except KeyError as exc:
        missing = "arrays.npz is missing" if not arrays_path.is_file() else f"it has no array {exc.args[0]!r}"
        raise ConfigError(f"{arrays_path}: {missing}, which a saved {doc.get('model')} model needs") from None
    except ConfigError as exc:  # the model's own check of what it was handed: name the folder
        raise ConfigError(f"{folder}: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - any failure to rebuild from these files is bad input
        # One line: torch's "Error(s) in loading state_dict" says what differs on its next lines.
        reason = " ".join(line.strip() for line in str(exc).splitlines() if line.strip())[:240] or type(exc).__name__
        raise ConfigError(
            f"{folder}: its model.json and arrays.npz do not make a {doc.get('model')} model ({reason})"
        ) from None


def _read_arrays(path: Path) -> dict[str, np.ndarray]:
    """Plain arrays of an ``.npz``; a pickle or an object array is refused, never loaded."""
    try:
        with np.load(path, allow_pickle=False) as npz:
            return {k: npz[k] for k in npz.files}
    except ValueError:  # numpy's refusal of pickled data and of object arrays
        raise ConfigError(f"{path}: holds pickled or object data, which tendon-id never loads") from None
    except (zipfile.BadZipFile, EOFError, OSError) as exc:
        raise ConfigError(f"{path}: not a readable .npz of arrays ({type(exc).__name__}: {exc})") from None
