"""The hostile cases of issue 42, each an input made in a scratch folder and one ``tendon-id`` command.

``prepare(run, base)`` makes what the cases start from with the tree under test (``run(argv,
cwd)`` runs its CLI); each :class:`Case` copies what it needs into its own folder, damages it,
and returns the command, and ``needle`` is what the one-line error must say.
``tests/cli/test_hostile_inputs.py`` runs them in process; ``perf/attack_table.py`` runs them as
processes before and after issue 42, for the table of its note.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import shutil
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np


def bench_csv(path: Path, scale: float = 1.0, n: int = 2000) -> None:
    """A synthetic cable bench at 1 kHz: motor and tip load cells [mN] and the motor angle [deg]."""
    t = np.arange(n) * 1e-3
    pos = 0.6 * np.sin(2 * np.pi * 3.0 * t) + 0.1 * np.sin(2 * np.pi * 0.7 * t)
    fin = 30 + 12 * pos + 3 * np.sin(2 * np.pi * 11 * t)
    fout = 0.9 * fin - np.sign(np.gradient(pos)) + 0.05 * np.random.default_rng(0).standard_normal(n)
    rows = [
        f"{t[i] * 1e3:.3f},{float(fin[i] * 1e3 * scale)!r},{float(fout[i] * 1e3 * scale)!r},{np.degrees(pos[i]):.6f}"
        for i in range(n)
    ]
    path.write_text("time_ms,F_motor,F_tip,motor\n" + "\n".join(rows) + "\n")


MAPPING = """kind = "passage"
quantity = "tension"
[file]
comment = "#"
header = true
delimiter = ","
trajectory = "file"
[columns]
t = { column = "time_ms", unit = "ms" }
input = { column = "F_motor", unit = "mN" }
output = { column = "F_tip", unit = "mN" }
position = { column = "motor", unit = "deg" }
[geometry]
wrap_angle = "infer"
"""


def prepare(run: Callable[[list[str], Path], dict], base: Path) -> None:
    """The inputs every case starts from, made by the tree under test."""
    base.mkdir(parents=True)
    steps = [
        ["simulate", "--protocol", "posterior-6", "--frames", "300", "--seed", "3", "--out", "p.csv"],
        ["simulate", "--protocol", "single-passage", "--frames", "200", "--seed", "3", "--out", "two.csv"],
        ["fit", "capstan-simple", "--data", "p.csv", "--out", "cap"],
        ["fit", "mlp", "--data", "p.csv", "--set", 'preset="tiny"', "--out", "mlp"],
    ]
    bench_csv(base / "b.csv")
    (base / "b.toml").write_text(MAPPING)
    steps.append(["fit", "passage-capstan", "--mapping", "b.toml", "--data", "b.csv", "--out", "pas"])
    for argv in steps:
        r = run(argv, base)
        if r["code"] != 0:
            raise RuntimeError(f"preparing {argv}: {r['stderr'][-400:]}")


@dataclass(frozen=True)
class Case:
    """One hostile input: ``setup(base, work)`` makes it in ``work`` and returns the command's arguments."""

    id: str
    what: str
    setup: Callable[[Path, Path], list[str]]
    timeout: float = 120.0
    after: Callable[[Path], str] | None = None
    needle: str = ""
    code: int = 2


# ---- helpers that damage a copy ----------------------------------------------------------------
def _copy(base: Path, work: Path, *names: str) -> None:
    for n in names:
        src = base / n
        (shutil.copytree if src.is_dir() else shutil.copy)(src, work / n)
        side = src.with_suffix(".json")
        if src.suffix == ".csv" and side.exists():
            shutil.copy(side, work / side.name)


def _edit_json(path: Path, change: Callable[[dict], None]) -> None:
    doc = json.loads(path.read_text())
    change(doc)
    path.write_text(json.dumps(doc))


def _reseal(folder: Path) -> None:
    """Record arrays.npz's digest (and members, where numpy reads it) in model.json, as a deliberate forger would."""
    doc = json.loads((folder / "model.json").read_text())
    blob = (folder / "arrays.npz").read_bytes()
    if isinstance(doc.get("arrays"), dict):
        doc["arrays"].update(sha256=hashlib.sha256(blob).hexdigest(), bytes=len(blob))
        doc["arrays"].pop("members", None)
    (folder / "model.json").write_text(json.dumps(doc))


def _npy(shape, data: bytes, dtype="<f8") -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": dtype, "fortran_order": False, "shape": shape})
    return buf.getvalue() + data


def _raw_npz(folder: Path, members: dict, compress=zipfile.ZIP_STORED) -> None:
    with zipfile.ZipFile(folder / "arrays.npz", "w", compression=compress) as zf:
        for name, raw in members.items():
            zf.writestr(name + ".npy", raw)
    _reseal(folder)


def _model(name: str, tamper: Callable[[Path], None], data: str = "p.csv") -> Callable[[Path, Path], list[str]]:
    def setup(base: Path, work: Path) -> list[str]:
        _copy(base, work, name, data)
        tamper(work / name)
        return ["evaluate", "--model", name, "--data", data]

    return setup


def _doc(change: Callable[[dict], None]) -> Callable[[Path], None]:
    return lambda folder: _edit_json(folder / "model.json", change)


def _mapping(old: str, new: str, cmd: str = "info") -> Callable[[Path, Path], list[str]]:
    def setup(base: Path, work: Path) -> list[str]:
        _copy(base, work, "b.csv")
        (work / "m.toml").write_text(MAPPING.replace(old, new))
        if cmd == "info":
            return ["info", "--mapping", "m.toml", "b.csv"]
        return ["calibrate", "--model", "passage-capstan", "--mapping", "m.toml", "--data", "b.csv", "--out", "o"]

    return setup


def _meta(change: Callable[[dict], None], cmd: list[str]) -> Callable[[Path, Path], list[str]]:
    def setup(base: Path, work: Path) -> list[str]:
        _copy(base, work, "p.csv")
        _edit_json(work / "p.json", change)
        return cmd

    return setup


def _in(base_name: str, argv: list[str]) -> Callable[[Path, Path], list[str]]:
    def setup(base: Path, work: Path) -> list[str]:
        for n in base_name.split(","):
            _copy(base, work, n)
        return argv

    return setup


def _bench(scale: float) -> Callable[[Path, Path], list[str]]:
    def setup(base: Path, work: Path) -> list[str]:
        bench_csv(work / "b.csv", scale)
        (work / "m.toml").write_text(MAPPING)
        return ["calibrate", "--model", "passage-capstan", "--mapping", "m.toml", "--data", "b.csv", "--out", "o"]

    return setup


def _fifo(base: Path, work: Path) -> list[str]:
    os.mkfifo(work / "f.csv")
    return ["info", "f.csv"]


def _dev_zero(base: Path, work: Path) -> list[str]:
    os.symlink("/dev/zero", work / "z.csv")
    return ["info", "z.csv"]


def _mixed(folder: Path) -> None:
    arrays = dict(np.load(folder / "arrays.npz"))
    np.savez(folder / "arrays.npz", **{k: v * 1.01 if v.dtype.kind == "f" else v for k, v in arrays.items()})


def _nan_weights(folder: Path) -> None:
    from safetensors.numpy import load, save

    arrays = dict(np.load(folder / "arrays.npz"))
    w = load(arrays["weights_safetensors"].tobytes())
    k = sorted(w)[0]
    w[k] = np.full_like(w[k], np.nan)
    np.savez(folder / "arrays.npz", weights_safetensors=np.frombuffer(save(w), dtype=np.uint8))
    _reseal(folder)


def _savez_resealed(**arrays) -> Callable[[Path], None]:
    def tamper(folder: Path) -> None:
        np.savez(folder / "arrays.npz", **arrays)
        _reseal(folder)

    return tamper


def _ls(name: str) -> Callable[[Path], str]:
    return lambda work: f"{name}/ {'exists' if (work / name).exists() else 'absent'}"


def _json_valid(path: str) -> Callable[[Path], str]:
    def check(work: Path) -> str:
        p = work / path
        if not p.exists():
            return f"no {path}"
        try:
            json.loads(p.read_text(), parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)))
            return f"{path} valid JSON"
        except ValueError as exc:
            return f"{path} NOT valid JSON ({exc})"

    return check


def _not_utf8(folder: Path) -> None:
    (folder / "model.json").write_bytes(b'{"model": "\xff"}')


def _one_frame(base: Path, work: Path) -> list[str]:
    lines = (base / "p.csv").read_text().splitlines()
    (work / "one.csv").write_text("\n".join(lines[:2]) + "\n")
    shutil.copy(base / "p.json", work / "one.json")
    return ["fit", "capstan-simple", "--data", "one.csv", "--out", "m"]


CASES = [
    # 1. one unit
    Case(
        "1a",
        "arrays.npz of another fit beside model.json",
        _model("cap", _mixed),
        needle="does not belong with model.json",
    ),
    Case(
        "1b",
        "a cut-off arrays.npz",
        _model("cap", lambda f: (f / "arrays.npz").write_bytes((f / "arrays.npz").read_bytes()[:200])),
        needle="does not belong with model.json",
    ),
    # 2. NaN as a result
    Case(
        "2a",
        "calibrate passage-capstan on tensions near 1e308",
        _bench(1.5e303),
        after=_json_valid("o/calibration.json"),
        needle="beyond +-1e+150",
    ),
    Case(
        "2b",
        "calibrate passage-capstan on denormal tensions",
        _bench(1e-320),
        after=_json_valid("o/calibration.json"),
        needle="subnormal",
    ),
    Case(
        "2c",
        "calibrate with wrap_angle = 1e300",
        _mapping('wrap_angle = "infer"', "wrap_angle = 1e300", "calibrate"),
        after=_json_valid("o/calibration.json"),
        needle="geometry.wrap_angle must be in",
    ),
    # 3. exit 1 for a user's mistake
    Case(
        "3a",
        "model.json a JSON list",
        _model("cap", lambda f: (f / "model.json").write_text("[1, 2]")),
        needle="a JSON list, not an object",
    ),
    Case(
        "3b",
        "model.json a JSON string",
        _model("cap", lambda f: (f / "model.json").write_text('"capstan"')),
        needle="a JSON str, not an object",
    ),
    Case(
        "3c",
        "model.json nested 100 000 deep",
        _model("cap", lambda f: (f / "model.json").write_text("[" * 100_000)),
        needle="nested too deeply",
    ),
    Case("3d", "model.json not UTF-8", _model("cap", _not_utf8), needle="not UTF-8"),
    Case(
        "3e",
        '"model": ["capstan-simple"]',
        _model("cap", _doc(lambda d: d.update(model=["capstan-simple"]))),
        needle="must be a model's name",
    ),
    Case(
        "3f",
        'params.n_starts = "many" in model.json',
        _model("cap", _doc(lambda d: d["params"].update(n_starts="many"))),
        needle="model.json: params.n_starts",
    ),
    Case(
        "3g",
        "fit --set robot=[1,2]",
        _in("p.csv", ["fit", "capstan-simple", "--data", "p.csv", "--set", "robot=[1,2]", "--out", "m"]),
        needle="robot must be a table",
    ),
    Case(
        "3h",
        'fit --set maxeval="abc"',
        _in("p.csv", ["fit", "capstan-simple", "--data", "p.csv", "--set", 'maxeval="abc"', "--out", "m"]),
        needle="maxeval: must be a whole number",
    ),
    Case(
        "3i",
        'fit mlp --set device="cuda" on a CPU machine',
        _in(
            "p.csv", ["fit", "mlp", "--data", "p.csv", "--set", 'preset="tiny"', "--set", 'device="cuda"', "--out", "m"]
        ),
        needle="device 'cuda' is not available",
    ),
    Case(
        "3j",
        "simulate --seed -1",
        _in("p.csv", ["simulate", "--seed", "-1", "--frames", "100", "--out", "x.csv"]),
        needle="--seed",
    ),
    Case(
        "3k",
        "diagnose --jobs 0",
        _in("p.csv", ["diagnose", "--base", "capstan-nonsmooth", "--data", "p.csv", "--jobs", "0", "--out", "d.html"]),
        needle="--jobs: must be a number of workers",
    ),
    Case(
        "3l",
        'metadata noise_n = "x" (identifiability)',
        _meta(lambda d: d["sensors"].update(noise_n="x"), ["identifiability", "--data", "p.csv", "--out", "i.html"]),
        300,
        needle="sensors.noise_n",
    ),
    Case(
        "3m",
        "metadata noise_n = -1 (identifiability)",
        _meta(lambda d: d["sensors"].update(noise_n=-1), ["identifiability", "--data", "p.csv", "--out", "i.html"]),
        300,
        needle="sensors.noise_n",
    ),
    Case(
        "3n",
        "metadata noise_n = NaN (identifiability)",
        _meta(
            lambda d: d["sensors"].update(noise_n=float("nan")),
            ["identifiability", "--data", "p.csv", "--out", "i.html"],
        ),
        300,
        needle="sensors.noise_n",
    ),
    Case(
        "3o",
        "mapping comment = 5",
        _mapping('comment = "#"', "comment = 5"),
        needle="[file] comment must be one character",
    ),
    Case(
        "3p",
        "mapping with a 30-digit scale",
        _mapping('unit = "mN" }', 'unit = "mN", scale = 123456789012345678901234567890 }'),
        needle="implausibly large",
    ),
    Case("3q", "unit s * 10**400", _mapping('unit = "ms"', 'unit = "s * 10**400"'), needle="power 400 is beyond"),
    Case(
        "3r",
        "metadata n_modules = 10**30",
        _meta(lambda d: d.update(n_modules=10**30), ["info", "p.csv"]),
        needle="n_modules is 1000000000000000000000000000000 in the metadata",
    ),
    Case(
        "3s",
        "evaluate a passage model on snake data",
        _in("pas,p.csv", ["evaluate", "--model", "pas", "--data", "p.csv"]),
        needle="got p.csv (Recording)",
    ),
    Case(
        "3t",
        "evaluate a snake model on bench data",
        _in("cap,b.csv,b.toml", ["evaluate", "--model", "cap", "--mapping", "b.toml", "--data", "b.csv"]),
        needle="b.csv is a PassageRecording",
    ),
    # 4. bounded work
    Case(
        "4a",
        "unit s * 10**10**8",
        _mapping('unit = "ms"', 'unit = "s * 10**10**8"'),
        150,
        needle="a power's exponent must be a plain number",
    ),
    Case(
        "4b",
        "state.config.hidden of 100 000 in model.json",
        _model(
            "mlp", _doc(lambda d: d["state"]["config"].update(hidden=[100_000] * len(d["state"]["config"]["hidden"])))
        ),
        needle="in the configuration but",
    ),
    Case(
        "4c",
        ".npy header claiming 2^40 elements",
        _model("cap", lambda f: _raw_npz(f, {"A": _npy((1 << 40,), b"\0" * 24), "B": _npy((1, 3), b"\0" * 24)})),
        needle="its header promises 8796093022208 bytes",
    ),
    Case(
        "4d",
        "a zip bomb member (128 MB from 130 kB)",
        _model(
            "cap",
            lambda f: _raw_npz(
                f, {"A": _npy((1, 1 << 24), b"\0" * (8 << 24)), "B": _npy((1, 3), b"\0" * 24)}, zipfile.ZIP_DEFLATED
            ),
        ),
        needle="unpacks to",
    ),
    Case(
        "4e",
        "metadata n_modules = 10**6",
        _meta(lambda d: d.update(n_modules=10**6), ["info", "p.csv"]),
        needle="n_modules is 1000000 in the metadata",
    ),
    Case("4f", "a FIFO as data", _fifo, 30, needle="is a FIFO, not a regular file"),
    Case("4g", "/dev/zero (through a link) as data", _dev_zero, 30, needle="is a device, not a regular file"),
    # 5. leftovers
    Case(
        "5b",
        "calibrate refused at fit time (passage model, snake data)",
        _in("p.csv", ["calibrate", "--model", "passage-capstan", "--data", "p.csv", "--out", "o"]),
        after=_ls("o"),
        needle="expected bench passage recordings",
    ),
    # 6. messages that blame the wrong thing
    Case(
        "6a",
        "a short .npy",
        _model("cap", lambda f: _raw_npz(f, {"A": _npy((1, 3), b"\0" * 10), "B": _npy((1, 3), b"\0" * 24)})),
        needle="its header promises 24 bytes of data but the member holds 10",
    ),
    Case(
        "6b",
        "a missing state key",
        _model("cap", _doc(lambda d: d["state"].pop("n_modules"))),
        needle="model.json: has no state entry 'n_modules'",
    ),
    Case(
        "6c",
        "an infinite unit factor",
        _mapping('unit = "ms"', 'unit = "s * 1e308 * 10"'),
        needle="gives a factor of inf",
    ),
    Case(
        "6d",
        "mapping wrap_angle = inf",
        _mapping('wrap_angle = "infer"', "wrap_angle = inf"),
        needle="m.toml: geometry.wrap_angle",
    ),
    Case(
        "6e",
        "an unknown model name in model.json",
        _model("cap", _doc(lambda d: d.update(model="nope"))),
        needle="model.json: unknown model 'nope'",
    ),
    Case(
        "6f",
        "a 12-module model on 2-module data",
        _model("cap", lambda f: None, data="two.csv"),
        needle="but two.csv has 2",
    ),
    # 7. checks that were missing
    Case(
        "7a",
        "B < |A| in a model file",
        _model("cap", _savez_resealed(A=np.full((1, 3), 0.3), B=np.full((1, 3), 0.1))),
        needle="B < |A|",
    ),
    Case(
        "7b",
        "complex arrays in a model file",
        _model("cap", _savez_resealed(A=np.zeros((1, 3), complex), B=np.ones((1, 3), complex))),
        needle="holds complex numbers",
    ),
    Case("7c", "a neural model with NaN weights", _model("mlp", _nan_weights), needle="holds NaN or inf"),
    Case(
        "7d",
        "diagnose --test the same file as --data",
        _in(
            "p.csv",
            ["diagnose", "--base", "capstan-nonsmooth", "--data", "p.csv", "--test", "p.csv", "--out", "d.html"],
        ),
        300,
        needle="is both a training and a held-out file",
    ),
    Case(
        "7e", 'mapping header = "no"', _mapping("header = true", 'header = "no"'), needle="header must be true or false"
    ),
    Case(
        "7f",
        "fit --set xtol_rel=NaN",
        _in("p.csv", ["fit", "capstan-simple", "--data", "p.csv", "--set", "xtol_rel=NaN", "--out", "m"]),
        needle="xtol_rel: must be a positive number",
    ),
    Case("7g", "a 1-frame fit", _one_frame, needle="warning: one.csv: fitting on 1 frame(s)", code=0),
]
