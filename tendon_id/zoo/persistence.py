"""Reading a saved model back: ``model.json`` names the model, the registry gives its class."""

from __future__ import annotations

import json
import os
from pathlib import Path

from tendon_id.atomic import sha256_file
from tendon_id.errors import ConfigError
from tendon_id.zoo.arrays_file import read_arrays
from tendon_id.zoo.estimator import ARRAYS_FILE, ARRAYS_KEY, FORMAT_VERSION, Estimator
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
        doc = json.loads(doc_path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise ConfigError(f"{doc_path}: not valid JSON ({exc})") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{doc_path}: not UTF-8 text (byte {exc.start})") from None
    except RecursionError:  # json's parser recurses once per nesting level
        raise ConfigError(f"{doc_path}: nested too deeply to be a model file") from None
    if not isinstance(doc, dict):
        raise ConfigError(f"{doc_path}: not a model file (a JSON {type(doc).__name__}, not an object)")
    if doc.get("format") != FORMAT_VERSION:
        raise ConfigError(f"{doc_path}: unsupported model format {doc.get('format')!r}")
    if not isinstance(doc.get("model"), str):
        raise ConfigError(f'{doc_path}: its "model" must be a model\'s name (a string), got {doc.get("model")!r:.60}')
    try:
        cls = model_class(doc["model"])
    except ConfigError as exc:
        raise ConfigError(f"{doc_path}: {exc.reason}") from None
    arrays_path = folder / ARRAYS_FILE
    check_arrays_digest(doc_path, doc.get(ARRAYS_KEY), arrays_path)
    record = doc.get(ARRAYS_KEY)
    members = record.get("members") if isinstance(record, dict) else None
    if members is not None and not isinstance(members, dict):
        raise ConfigError(f'{doc_path}: its "{ARRAYS_KEY}.members" entry is not an object')
    arrays = read_arrays(arrays_path, members) if arrays_path.is_file() else {}
    params = doc.get("params", {})
    if not isinstance(params, dict):
        raise ConfigError(f'{doc_path}: its "params" must be an object of settings')
    try:  # the settings, as a fit would check them: a hand-edited one is blamed on model.json
        cls(**params).check_settings()
    except ConfigError as exc:
        raise ConfigError(
            f"{doc_path}: params.{exc.param}: {exc.reason}" if exc.param else f"{doc_path}: {exc}"
        ) from None
    except TypeError as exc:  # a setting the model does not have
        raise ConfigError(f"{doc_path}: params: {exc}") from None
    try:
        state = doc.get("state", {})
        return cls.from_saved(
            params,
            _Blaming(state, doc_path, "state entry") if isinstance(state, dict) else state,
            _Blaming(arrays, arrays_path, "array"),
        )
    except _Missing as exc:
        path, what, key = exc.args
        if path == arrays_path and not arrays_path.is_file():
            raise ConfigError(f"{arrays_path}: missing, and a saved {doc['model']} model needs it") from None
        raise ConfigError(f"{path}: has no {what} {key!r}, which a saved {doc['model']} model needs") from None
    except ConfigError as exc:  # the model's own check of what it was handed: name the folder
        raise ConfigError(f"{folder}: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - any failure to rebuild from these files is bad input
        # One line: torch's "Error(s) in loading state_dict" says what differs on its next lines.
        reason = " ".join(line.strip() for line in str(exc).splitlines() if line.strip())[:240] or type(exc).__name__
        raise ConfigError(
            f"{folder}: its model.json and arrays.npz do not make a {doc.get('model')} model ({reason})"
        ) from None


class _Missing(KeyError):
    """A key the model needed: (file, what, key), so the message blames the file that lacks it."""


class _Blaming(dict):
    """A dict whose missing key raises :class:`_Missing` naming the file it was read from."""

    def __init__(self, items, path: Path, what: str) -> None:
        super().__init__(items)
        self._where = (path, what)

    def __missing__(self, key):
        raise _Missing(*self._where, key)


def check_arrays_digest(doc_path: Path, record, arrays_path: Path) -> None:
    """Refuse an ``arrays.npz`` that is not the one ``model.json`` was saved with.

    ``record`` is ``model.json``'s ``"arrays"`` entry (``file``, ``sha256``, ``bytes``); a model
    saved before the digest was recorded has none and is read as before.
    """
    if record is None:
        return
    if not isinstance(record, dict) or not isinstance(record.get("sha256"), str):
        raise ConfigError(f"{doc_path}: its {ARRAYS_KEY!r} entry is not an object with a sha256 string")
    if not arrays_path.is_file():
        raise ConfigError(f"{arrays_path}: missing; {doc_path.name} was saved with it")
    size = arrays_path.stat().st_size
    if (isinstance(record.get("bytes"), int) and size != record["bytes"]) or sha256_file(arrays_path) != record[
        "sha256"
    ]:
        raise ConfigError(
            f"{arrays_path}: does not belong with {doc_path.name} (its SHA-256 is not the one recorded there): the "
            "folder mixes two saves, or the file was cut off or changed; fit again into the folder"
        )
