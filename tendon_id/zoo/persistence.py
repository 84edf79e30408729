"""Reading a saved model back: ``model.json`` names the model, the registry gives its class."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from tendon_id.errors import ConfigError
from tendon_id.zoo.estimator import FORMAT_VERSION, Estimator
from tendon_id.zoo.registry import model_class


def load_model(path: str | os.PathLike) -> Estimator:
    """Load a model saved by :meth:`TransmissionModel.save`.

    Only the saved model's own module is imported (a capstan model loads without torch).

    Raises
    ------
    ConfigError
        Naming the folder, if it holds no model or an unknown one.
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
    arrays = {}
    if arrays_path.is_file():
        with np.load(arrays_path, allow_pickle=False) as npz:
            arrays = {k: npz[k] for k in npz.files}
    return cls.from_saved(doc.get("params", {}), doc.get("state", {}), arrays)
