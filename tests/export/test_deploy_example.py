"""The deployment guide's C program (docs/guide/deploy/main.c), compiled and run as the guide says, so it cannot rot."""

import io
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from export_helpers import stream_recording

from tendon_id import zoo
from tendon_id.benchmarks.latency import untrained_model
from tendon_id.data import Recording
from tendon_id.export import export_model
from tendon_id.zoo.inputs import TransmissionInputs

MAIN = Path(__file__).resolve().parents[2] / "docs" / "guide" / "deploy" / "main.c"


@pytest.fixture(scope="module")
def csv_recording(recordings, tmp_path_factory):
    """The test recording written as CSV (its sidecar JSON beside it), as ``tendon-id simulate --out x.csv`` does."""
    _, test = recordings
    return test.write(tmp_path_factory.mktemp("csv") / "recording.csv")


def build(compiler, export: Path, tmp_path: Path) -> Path:
    """The guide's build line, with warnings as errors."""
    exe = tmp_path / "stream"
    cmd = [compiler, "-O2", "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-I", str(export)]
    run = subprocess.run([*cmd, "-o", str(exe), str(MAIN), str(export / "tendon_model.c"), "-lm"], capture_output=True)
    assert run.returncode == 0, run.stderr.decode()
    return exe


@pytest.mark.parametrize("name", ["capstan-nonsmooth", "pg-chtc"])
def test_the_guide_program_prints_the_streamers_tensions(recordings, csv_recording, tmp_path, compiler, name):
    train, _ = recordings
    if name == "pg-chtc":
        model = untrained_model(train, "tiny")  # random weights: what is checked here is the program, not the model
    else:
        model = zoo.make(name, n_starts=1, maxeval=60).fit(train)
    exe = build(compiler, export_model(model, "c", tmp_path / "model-c"), tmp_path)
    run = subprocess.run([str(exe), str(csv_recording)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    printed = pd.read_csv(io.StringIO(run.stdout), dtype={"trajectory": str})
    rec = Recording.read(csv_recording)  # what the program read
    n = rec.n_modules
    assert list(printed.columns[2:]) == [f"tension_hat_{j}_{i}" for j in range(1, n + 1) for i in (1, 2, 3)]
    assert list(printed["trajectory"].unique()) == list(rec.trajectories)
    assert printed["frame"].iloc[0] == 0 and printed["frame"].max() < rec.n_frames - 1  # restarted per trajectory
    reset = TransmissionInputs.from_recordings(rec).reset
    ref = stream_recording(model.streamer(), rec.angles, rec.actuator, reset)
    out = printed.iloc[:, 2:].to_numpy().reshape(ref.shape)
    assert np.max(np.abs(out / ref - 1.0)) <= (1e-5 if name == "pg-chtc" else 1e-12)


def test_the_guide_program_names_a_missing_column(recordings, csv_recording, tmp_path, compiler):
    train, _ = recordings
    model = zoo.make("capstan-simple").fit(train)
    exe = build(compiler, export_model(model, "c", tmp_path / "model-c"), tmp_path)
    frame = pd.read_csv(csv_recording).drop(columns=["theta_7_y"])
    frame.to_csv(tmp_path / "partial.csv", index=False)
    run = subprocess.run([str(exe), str(tmp_path / "partial.csv")], capture_output=True, text=True)
    assert run.returncode == 2 and "no column theta_7_y" in run.stderr and run.stdout == ""
