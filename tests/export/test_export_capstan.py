"""The capstan family exported: ONNX and C agree with ``streamer().step`` over a whole recording, any N and m."""

import json

import numpy as np
import pytest
from export_helpers import stream_recording, strict_c

from tendon_id import zoo
from tendon_id.export import export_files, export_model
from tendon_id.export.run import OnnxStep
from tendon_id.export.spec import ExportError
from tendon_id.geometry import RobotGeometry


@pytest.fixture(scope="module")
def nonsmooth(recordings):
    train, _ = recordings
    return zoo.make("capstan-nonsmooth", n_starts=1, maxeval=60).fit(train)


def family(nonsmooth):
    """The family at the calibrated law, without calibrating again: each variant's step differs."""
    A, B, geo = nonsmooth.A_, nonsmooth.B_, nonsmooth.geometry_
    values = nonsmooth.block_values_
    per_guide = (np.repeat(A, 11, axis=0) * np.linspace(0.5, 1.5, 11)[:, None], np.repeat(B, 11, axis=0))
    hard = [{"block": "contact", "gate": "hard", "alpha_c": 0.05}, "hysteresis"]
    return {
        "capstan-nonsmooth": nonsmooth,
        "capstan-nonsmooth per-guide": zoo.make("capstan-nonsmooth", tying="per-guide").fitted_with(
            *per_guide, geo, 12, values
        ),
        "capstan-simple": zoo.make("capstan-simple").fitted_with(A, B, geo, 12, {"routing": values["routing"]}),
        "capstan-contact": zoo.make("capstan-contact").fitted_with(A, B, geo, 12, values),
        "capstan-const-mu": zoo.make("capstan-const-mu").fitted_with(0 * A, B, geo, 12, {"routing": values["routing"]}),
        "capstan hard gate": zoo.make("capstan", blocks=hard).fitted_with(
            A, B, geo, 12, {"routing": values["routing"]}
        ),
    }


VARIANTS = [
    "capstan-nonsmooth",
    "capstan-nonsmooth per-guide",
    "capstan-simple",
    "capstan-contact",
    "capstan-const-mu",
    "capstan hard gate",
]


def _check(model, runner_class, fmt, tmp_path, frames, tol=1e-12):
    angles, actuator, reset = frames
    folder = export_model(model, fmt, tmp_path / fmt)
    ref = stream_recording(model.streamer(), angles, actuator, reset)
    out = stream_recording(runner_class(folder), angles, actuator, reset)
    rel = np.max(np.abs(out / ref - 1.0))
    assert rel <= tol, f"{fmt}: max relative deviation {rel:.2e}, absolute {np.max(np.abs(out - ref)):.2e} N"
    np.testing.assert_array_equal(out[:, 0], actuator[:, 0])  # set 1 is its reading, exactly
    return out, ref


@pytest.mark.parametrize("variant", VARIANTS)
def test_onnx_agrees_with_the_streamer(nonsmooth, variant, tmp_path, frames):
    """float64 throughout, the blocks' own order of operations: measured within 2e-15 relative (3e-13 N)."""
    _check(family(nonsmooth)[variant], OnnxStep, "onnx", tmp_path, frames)


@pytest.mark.parametrize("variant", VARIANTS)
def test_c_agrees_with_the_streamer(nonsmooth, variant, tmp_path, frames, compiler):
    """Measured: the same bits (libm's log, exp and cos against numpy's)."""
    _check(family(nonsmooth)[variant], strict_c, "c", tmp_path, frames)


def test_the_exported_step_keeps_the_stick_state(nonsmooth, tmp_path, frames):
    """Hysteresis in the export: the contact-only law with the same parameters gives other tensions."""
    out, _ = _check(nonsmooth, OnnxStep, "onnx", tmp_path, frames)
    slip = stream_recording(family(nonsmooth)["capstan-contact"].streamer(), *frames)
    assert np.max(np.abs(out / slip - 1.0)) > 1e-3


@pytest.mark.parametrize("fmt", ["onnx", "c"])
def test_any_module_and_tendon_count(fmt, tmp_path, request):
    """N = 4 modules of m = 2 tendons, read from the law's arrays: nothing assumes 12 or 3."""
    if fmt == "c":
        request.getfixturevalue("compiler")
    n, m, steps = 4, 2, 40
    rng = np.random.default_rng(0)
    angles = np.cumsum(rng.normal(0, 0.05, (steps, n, 2)), axis=0)
    actuator = 40 + 10 * np.abs(np.cumsum(rng.normal(0, 1, (steps, n, m)), axis=0))
    reset = np.arange(steps) % 20 == 0
    model = zoo.make("capstan-nonsmooth", tying="per-guide").fitted_with(
        np.full((n - 1, m), 0.1), np.linspace(0.2, 0.4, (n - 1) * m).reshape(n - 1, m), RobotGeometry.from_dict(
            {"n_modules": n}
        ), n, {"routing": {"alpha_0": 0.05}, "contact": {"alpha_c": 0.02}}
    )  # fmt: skip
    folder = export_model(model, fmt, tmp_path / fmt)
    manifest = json.loads((folder / "export.json").read_text())
    assert (manifest["n_modules"], manifest["n_tendons"]) == (n, m)
    runner = OnnxStep(folder) if fmt == "onnx" else strict_c(folder)
    out = stream_recording(runner, angles, actuator, reset)
    ref = stream_recording(model.streamer(), angles, actuator, reset)
    assert out.shape == (steps, n, m)
    np.testing.assert_allclose(out, ref, rtol=1e-12, atol=0)


@pytest.mark.parametrize("fmt", ["onnx", "c"])
def test_the_same_model_gives_the_same_bytes(nonsmooth, fmt, tmp_path):
    """Saved, loaded and exported again, to another folder: every file the same, byte for byte."""
    first = export_model(nonsmooth, fmt, tmp_path / "a")
    again = export_model(zoo.load(nonsmooth.save(tmp_path / "model")), fmt, tmp_path / "b")
    names = sorted(p.name for p in first.iterdir())
    assert names == sorted(p.name for p in again.iterdir())
    assert all((first / n).read_bytes() == (again / n).read_bytes() for n in names)


def test_the_onnx_graph_matches_its_description(nonsmooth):
    import onnxruntime

    files = export_files(nonsmooth, "onnx")
    manifest = json.loads(files["export.json"])
    session = onnxruntime.InferenceSession(files["model.onnx"], providers=["CPUExecutionProvider"])
    described = {e["name"]: e for e in manifest["inputs"] + manifest["state"]}
    inputs = {i.name: i for i in session.get_inputs()}
    assert set(described) == set(inputs) == {"angles", "actuator", "n_seen", "play_y"}
    for name, i in inputs.items():
        assert list(i.shape) == described[name]["shape"]
        assert i.type == f"tensor({'double' if described[name]['dtype'] == 'float64' else 'int64'})"
    assert [o.name for o in session.get_outputs()] == ["tensions", "n_seen_out", "play_y_out"]


def test_a_model_that_does_not_export_says_which_do(recordings):
    train, _ = recordings
    geometry = zoo.make("capstan-simple").fit(train).geometry_
    drifting = zoo.make("capstan", blocks=["velocity_friction"]).fitted_with(np.zeros(3), np.full(3, 0.2), geometry, 12)
    with pytest.raises(ExportError, match=r"velocity_friction.*formats onnx and c"):
        export_files(drifting, "c")
    with pytest.raises(ExportError, match=r"'proximal' cannot be exported.*pg-chtc.*capstan-nonsmooth"):
        export_files(zoo.make("proximal").fit(train), "onnx")
