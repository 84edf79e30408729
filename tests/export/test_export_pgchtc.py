"""PG-CHTC exported: ONNX and C agree with ``streamer().step`` to 1e-5 over a whole recording; the C is standalone."""

import copy
import json
import re
import subprocess

import numpy as np
import pytest
import torch
from export_helpers import stream_recording, strict_c

from learners import Cascade, preset
from tendon_id import zoo
from tendon_id.export import export_files, export_model
from tendon_id.export.run import CStep, OnnxStep
from tendon_id.export.spec import ExportError
from tendon_id.geometry import RobotGeometry
from tendon_id.zoo.learned import PGCHTC

#: Agreement with the streamer, relative (= absolute in ln T): float32 units summed in another order, as the
#: native and torch engines differ from each other.  Measured on the trained model: 4e-6 (ONNX), 4e-6 (C).
TOL = 1e-5


@pytest.fixture(scope="module")
def trained(recordings):
    """The tiny preset, trained on 300 frames (about 5 s); a given prior, as in tests/zoo/test_pgchtc.py."""
    train, _ = recordings
    prior = {"A": [0.1, 0.1, 0.1], "B": [0.2, 0.2, 0.2], "alpha_0": 0.05}
    with pytest.warns(UserWarning):  # the guard: this barely trained cascade is worse than its prior
        return zoo.make("pg-chtc", preset="tiny", prior=prior, progress=False).fit(train)


def random_model(trained, n: int, tied: bool, residual: bool, seed: int = 0) -> PGCHTC:
    """A pg-chtc model of ``n`` modules with random (untrained) units and the trained one's input normalisation."""
    torch.manual_seed(seed)
    cascade = Cascade(n - 1, preset("tiny", temporal_residual=residual).unit, tied=tied).eval()
    with torch.no_grad():
        for u in cascade.units:
            u.backbone.head.weight.mul_(0.3)  # ratios near 1, so that the chain does not amplify rounding
            if u.residual is not None:
                torch.nn.init.normal_(u.residual.head.weight, std=0.3)  # a residual that matters
                for layer in u.residual.layers:
                    torch.nn.init.normal_(layer.attn.lag_bias, std=1.0)  # lags that differ
        cascade.feature_mean.copy_(trained.cascade_.feature_mean)
        cascade.feature_std.copy_(trained.cascade_.feature_std)
    model = PGCHTC(preset="tiny", tied=tied, temporal_residual=residual, progress=False)
    model.cascade_, model.n_modules_, model.geometry_ = cascade, n, RobotGeometry.from_dict({"n_modules": n})
    model.prior_A_ = model.prior_B_ = np.zeros(3)
    model.history_ = {}
    return model


def variant(name, trained, frames):
    """(model, angles, actuator, reset) of a named case."""
    angles, actuator, reset = frames
    if name == "trained":
        return trained, angles, actuator, reset
    if name == "5 modules, a unit per guide":
        return random_model(trained, 5, tied=False, residual=True), angles[:, :5], actuator[:, :5], reset
    return random_model(trained, 12, tied=True, residual=False), angles, actuator, reset


VARIANTS = ["trained", "5 modules, a unit per guide", "without g_phi"]


def _agree(runner_class, fmt, name, trained, frames, tmp_path):
    model, angles, actuator, reset = variant(name, trained, frames)
    folder = export_model(model, fmt, tmp_path / fmt)
    ref = stream_recording(model.streamer(), angles, actuator, reset)
    out = stream_recording(runner_class(folder), angles, actuator, reset)
    rel = np.max(np.abs(out / ref - 1.0))
    assert rel <= TOL, f"{fmt} {name}: max relative deviation {rel:.2e}, absolute {np.max(np.abs(out - ref)):.2e} N"
    np.testing.assert_array_equal(out[:, 0], actuator[:, 0])
    assert np.ptp(out[:, -1] / actuator[:, -1]) > 1e-3  # the chain does something, frame to frame


@pytest.mark.parametrize("name", VARIANTS)
def test_onnx_agrees_with_the_streamer(trained, frames, tmp_path, name):
    _agree(OnnxStep, "onnx", name, trained, frames, tmp_path)


@pytest.mark.parametrize("name", VARIANTS)
def test_c_agrees_with_the_streamer(trained, frames, tmp_path, name, compiler):
    _agree(strict_c, "c", name, trained, frames, tmp_path)


def test_the_c_source_stands_alone(trained, tmp_path, compiler):
    """Only its own header and the C library; pedantic C99 without a warning; an object file with cc -O2 -c."""
    folder = export_model(trained, "c", tmp_path / "c", prefix="snake")
    source = (folder / "snake.c").read_text()
    includes = set(re.findall(r'#include\s+([<"][^>"]+[>"])', source + (folder / "snake.h").read_text()))
    assert includes == {'"snake.h"', "<math.h>", "<string.h>", "<stddef.h>"}
    strict = [compiler, "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-O2", "-c", "snake.c", "-o", "x.o"]
    run = subprocess.run(strict, cwd=folder, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    names = subprocess.run(["nm", "-g", "--defined-only", "x.o"], cwd=folder, capture_output=True, text=True)
    if names.returncode == 0:  # binutils present: the object exports the four functions and nothing else
        exported = {line.split()[-1] for line in names.stdout.splitlines() if line.strip()}
        assert exported == {"snake_init", "snake_reset", "snake_step", "snake_state_size"}


def test_a_refused_frame_changes_nothing(trained, frames, tmp_path, compiler):
    angles, actuator, _ = frames
    c = CStep(export_model(trained, "c", tmp_path / "c"))
    first = [c.step(angles[t], actuator[t]) for t in range(3)]
    bad = actuator[3].copy()
    bad[2, 1] = 0.0
    with pytest.raises(ValueError, match="refused"):
        c.step(angles[3], bad)
    c.reset()
    np.testing.assert_array_equal([c.step(angles[t], actuator[t]) for t in range(3)], first)


@pytest.mark.parametrize("fmt", ["onnx", "c"])
def test_the_same_model_gives_the_same_bytes(trained, fmt, tmp_path):
    again = zoo.load(trained.save(tmp_path / "model"))
    first, second = export_files(trained, fmt), export_files(again, fmt)
    assert first.keys() == second.keys() and all(first[k] == second[k] for k in first)


def test_the_description_names_the_state(trained):
    manifest = json.loads(export_files(trained, "onnx")["export.json"])
    cfg = trained.cascade_.cfg
    state = {e["name"]: e for e in manifest["state"]}
    shape = [cfg.n_layers, 11 * 12 // 2, cfg.n_heads, cfg.window, cfg.d_model // cfg.n_heads]
    assert state["keys"]["shape"] == state["values"]["shape"] == shape
    assert state["n_seen"]["initial"] == 0 and state["keys"]["initial"] == 0.0
    assert [e["units"] for e in manifest["inputs"]] == ["rad", "N"] and manifest["outputs"][0]["units"] == "N"


def test_a_model_that_falls_back_to_its_prior_does_not_export(trained):
    fallen = copy.copy(trained)
    fallen.guard_ = {**trained.guard_, "fallback": True}
    with pytest.raises(ExportError, match="predicts with its prior capstan-nonsmooth"):
        export_files(fallen, "c")
