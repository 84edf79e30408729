"""A model folder is input too: a tampered or foreign one exits 2 with one line naming the file (issue 19)."""

import hashlib
import io
import json
import pickle
import shutil
import zipfile

import numpy as np
import pytest

from tendon_id.cli import main
from tendon_id.zoo.arrays_file import members_record


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    root = tmp_path_factory.mktemp("models")
    data = root / "d.parquet"
    assert main(["simulate", "--protocol", "posterior-6", "--frames", "300", "--seed", "3", "--out", str(data)]) == 0
    assert main(["fit", "capstan-contact", "--data", str(data), "--out", str(root / "cap")]) == 0
    assert main(["fit", "mlp", "--data", str(data), "--set", 'preset="tiny"', "--out", str(root / "mlp")]) == 0
    return root


def _truncate(path, keep):
    path.write_bytes(path.read_bytes()[:keep])


def _widen(folder):
    doc = json.loads((folder / "model.json").read_text())
    doc["state"]["config"]["hidden"] = [h + 3 for h in doc["state"]["config"]["hidden"]]
    (folder / "model.json").write_text(json.dumps(doc))


def _format(folder, version):
    doc = json.loads((folder / "model.json").read_text())
    doc["format"] = version
    (folder / "model.json").write_text(json.dumps(doc))


def _resealed(write, record="update"):
    """Tamper with arrays.npz, then record its new digest in model.json: a folder whose files agree,
    so the content checks behind the digest are what refuses it."""

    def tamper(folder):
        write(folder)
        doc = json.loads((folder / "model.json").read_text())
        blob = (folder / "arrays.npz").read_bytes()
        doc["arrays"].update(sha256=hashlib.sha256(blob).hexdigest(), bytes=len(blob))
        if record != "update":  # "keep" the saved record, or "drop" it (a model saved before records)
            if record == "drop":
                del doc["arrays"]["members"]
            (folder / "model.json").write_text(json.dumps(doc))
            return
        try:  # the arrays' record too, where the new file is a zip of .npy headers numpy can read
            with np.load(folder / "arrays.npz", allow_pickle=True) as npz:
                doc["arrays"]["members"] = members_record({k: npz[k] for k in npz.files})
        except Exception:  # noqa: BLE001 - not an npz: the record stays as saved
            pass
        (folder / "model.json").write_text(json.dumps(doc))

    return tamper


def _mixed(folder):
    """arrays.npz of another fit (of the same model) beside this model.json: two saves mixed."""
    arrays = dict(np.load(folder / "arrays.npz"))
    arrays = {k: v * 1.01 if v.dtype.kind == "f" else v for k, v in arrays.items()}
    np.savez(folder / "arrays.npz", **arrays)


def _add_member(folder, name, value):
    arrays = dict(np.load(folder / "arrays.npz"))
    np.savez(folder / "arrays.npz", **arrays, **{name: value})


def _raw_npz(folder, members: dict, compress=zipfile.ZIP_STORED):
    """arrays.npz from raw member bytes (a header numpy would never write)."""
    with zipfile.ZipFile(folder / "arrays.npz", "w", compression=compress) as zf:
        for name, raw in members.items():
            zf.writestr(name + ".npy", raw)


def _npy(shape, data: bytes, dtype="<f8"):
    header = {"descr": dtype, "fortran_order": False, "shape": shape}
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, header)
    return buf.getvalue() + data  # the header writer writes the magic string too


def _short_npy(folder):
    _raw_npz(folder, {"A": _npy((1, 3), b"\0" * 40), "B": _npy((1, 3), b"\0" * 24)})


def _huge_header(folder):
    _raw_npz(folder, {"A": _npy((1 << 40,), b"\0" * 24), "B": _npy((1, 3), b"\0" * 24)})


def _bomb(folder):
    _raw_npz(folder, {"A": _npy((1, 1 << 24), b"\0" * (8 << 24)), "B": _npy((1, 3), b"\0" * 24)}, zipfile.ZIP_DEFLATED)


def _nan_weights(folder):
    from safetensors.numpy import load, save

    arrays = dict(np.load(folder / "arrays.npz"))
    weights = load(arrays["weights_safetensors"].tobytes())
    first = sorted(weights)[0]
    weights[first] = np.full_like(weights[first], np.nan)
    np.savez(folder / "arrays.npz", weights_safetensors=np.frombuffer(save(weights), dtype=np.uint8))


def _huge_hidden(folder):
    doc = json.loads((folder / "model.json").read_text())
    doc["state"]["config"]["hidden"] = [100_000] * len(doc["state"]["config"]["hidden"])  # 40 GB of float32
    (folder / "model.json").write_text(json.dumps(doc))


CASES = {
    "missing model.json": ("cap", lambda f: (f / "model.json").unlink(), "no model.json"),
    "missing arrays.npz": ("cap", lambda f: (f / "arrays.npz").unlink(), "arrays.npz: missing"),
    "arrays.npz of another save": ("cap", _mixed, "does not belong with model.json"),
    "a cut-off arrays.npz": ("cap", lambda f: _truncate(f / "arrays.npz", 50), "does not belong with model.json"),
    "truncated JSON": ("cap", lambda f: _truncate(f / "model.json", 40), "not valid JSON"),
    "unknown format version": ("cap", lambda f: _format(f, 99), "unsupported model format 99"),
    "a JSON list": ("cap", lambda f: (f / "model.json").write_text("[1, 2]"), "a JSON list, not an object"),
    "not UTF-8": ("cap", lambda f: (f / "model.json").write_bytes(b'{"model": "\xff"}'), "not UTF-8"),
    "nested 100 000 deep": ("cap", lambda f: (f / "model.json").write_text("[" * 100_000), "nested too deeply"),
    "a model name that is a list": (
        "cap",
        lambda f: (f / "model.json").write_text(json.dumps({"format": 1, "model": ["capstan-simple"]})),
        "must be a model's name",
    ),
    "a pickle for arrays": (
        "cap",
        _resealed(lambda f: (f / "arrays.npz").write_bytes(pickle.dumps({"A": 1}))),
        "not a readable .npz",
    ),
    "an object array": (
        "cap",
        _resealed(lambda f: np.savez(f / "arrays.npz", A=np.array([object()] * 3, dtype=object), B=np.ones((1, 3)))),
        "holds objects (pickled data)",
    ),
    "arrays of the wrong shape": (
        "cap",
        _resealed(lambda f: np.savez(f / "arrays.npz", A=np.ones((2, 5)), B=np.ones((1, 3)))),
        "do not fit a 12-module capstan law",
    ),
    "a truncated npz": ("cap", _resealed(lambda f: _truncate(f / "arrays.npz", 50)), "not a readable .npz"),
    "foreign safetensors": (
        "mlp",
        _resealed(
            lambda f: np.savez(f / "arrays.npz", weights_safetensors=np.frombuffer(b"not safetensors", dtype=np.uint8))
        ),
        "do not make a mlp model",
    ),
    # Valid safetensors of a narrower network than model.json describes: the tensors' shapes are off.
    "weights of another architecture": ("mlp", _widen, "in the configuration but"),
    "complex arrays": (
        "cap",
        _resealed(lambda f: np.savez(f / "arrays.npz", A=np.zeros((1, 3), complex), B=np.ones((1, 3), complex))),
        "holds complex numbers",
    ),
    "a law with B < |A| (negative friction)": (
        "cap",
        _resealed(lambda f: np.savez(f / "arrays.npz", A=np.full((1, 3), 0.3), B=np.full((1, 3), 0.1))),
        "B < |A|",
    ),
    "an array the record does not list": (
        "cap",
        _resealed(lambda f: _add_member(f, "evil", np.ones(3)), record="keep"),
        "evil",
    ),
    "a .npy cut short of its header's promise": ("cap", _resealed(_short_npy), "holds 40"),
    "a .npy header claiming 2^40 elements": ("cap", _resealed(_huge_header), "but model.json records <f8 (1, 3)"),
    "the same, in a model saved without a record": (
        "cap",
        _resealed(_huge_header, record="drop"),
        "promises 8796093022208 bytes",
    ),
    "a zip bomb member": ("cap", _resealed(_bomb), "unpacks to"),
    "weights with NaN": ("mlp", _resealed(_nan_weights), "holds NaN or inf"),
    "a configuration asking for 40 GB": ("mlp", _huge_hidden, "in the configuration but"),
    # A state entry the model needs, gone from model.json: blamed on model.json, not on arrays.npz.
    "a missing state entry": ("cap", lambda f: _drop_state(f), "model.json: has no state entry"),
}


def _drop_state(folder):
    doc = json.loads((folder / "model.json").read_text())
    doc["state"].pop("n_modules")  # a capstan model needs it
    (folder / "model.json").write_text(json.dumps(doc))


@pytest.mark.parametrize("case", list(CASES))
def test_a_tampered_model_folder_exits_2_naming_the_file(saved, tmp_path, capsys, case):
    src, tamper, needle = CASES[case]
    folder = tmp_path / "model"
    shutil.copytree(saved / src, folder)
    tamper(folder)
    code = main(["evaluate", "--model", str(folder), "--data", str(saved / "d.parquet")])
    err = capsys.readouterr().err
    assert code == 2, err
    assert needle in err and str(folder) in err and "Traceback" not in err and "internal error" not in err
    assert len(err.strip().splitlines()) == 1


def test_an_untampered_folder_still_loads(saved, capsys):
    for name in ("cap", "mlp"):
        assert main(["evaluate", "--model", str(saved / name), "--data", str(saved / "d.parquet")]) == 0


def test_a_model_for_another_robot_size_exits_2(saved, tmp_path, capsys):
    two = tmp_path / "rig.parquet"
    assert main(["simulate", "--protocol", "single-passage", "--frames", "200", "--out", str(two)]) == 0
    capsys.readouterr()
    code = main(["evaluate", "--model", str(saved / "cap"), "--data", str(two)])
    err = capsys.readouterr().err
    assert code == 2 and "12 modules" in err and "Traceback" not in err
