"""A model folder, and a CSV with its sidecar, are one unit (issue 42): a SIGTERM unwinds as a Ctrl-C does,
concurrent writers take turns, and nothing temporary outlives a run."""

import json
import signal
import threading
import time

import numpy as np
import pytest
from cli_helpers import files as _files
from cli_helpers import run

from tendon_id.data import Recording
from tendon_id.zoo import load, make


def test_a_sigterm_between_the_models_files_is_held_until_both_are_whole(recording, tmp_path, monkeypatch, capsys):
    import tendon_id.zoo.estimator as E

    real = E._write_blob

    def write_then_term(tmp, blob):
        real(tmp, blob)
        signal.raise_signal(signal.SIGTERM)  # a real SIGTERM, between arrays.npz and model.json

    monkeypatch.setattr(E, "_write_blob", write_then_term)
    out = tmp_path / "m"
    code, _, err = run(capsys, "fit", "capstan-simple", "--data", str(recording), "--out", str(out))
    assert code == 128 + signal.SIGTERM, err
    assert err.strip().startswith("tendon-id: terminated (SIGTERM); interrupted during writing the model; wrote only")
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert _files(out) == ["arrays.npz", "model.json"]
    load(out)  # the two files belong together


def test_a_sigterm_in_the_work_writes_nothing_and_leaves_no_temporary_file(recording, tmp_path, monkeypatch, capsys):
    def fit_then_term(self, *args, **kwargs):
        signal.raise_signal(signal.SIGTERM)

    monkeypatch.setattr("tendon_id.zoo.capstan.CapstanModel.fit", fit_then_term)
    out = tmp_path / "c"
    code, _, err = run(capsys, "calibrate", "--data", str(recording), "--model", "capstan-simple", "--out", str(out))
    assert code == 128 + signal.SIGTERM and "terminated (SIGTERM)" in err and "nothing written" in err, err
    assert not out.exists()  # not even an empty folder
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # the run's handler is gone with it


def test_a_calibration_that_refuses_its_data_leaves_no_empty_folder(recording, tmp_path, monkeypatch, capsys):
    from tendon_id.errors import ConfigError

    def refuse(self, *args, **kwargs):  # the fit's own checks of the data, after it was read
        raise ConfigError("the data cannot pin this law down")

    monkeypatch.setattr("tendon_id.zoo.capstan.CapstanModel.fit", refuse)
    out = tmp_path / "c"
    code, _, err = run(capsys, "calibrate", "--data", str(recording), "--model", "capstan-simple", "--out", str(out))
    assert code == 2 and "cannot pin this law down" in err, err
    assert not out.exists()


@pytest.fixture(scope="module")
def two_models(recording):
    rec = Recording.read(recording)
    return make("capstan-simple").fit(rec), make("capstan-contact").fit(rec)


def test_a_second_writer_to_one_folder_waits_for_the_first(two_models, tmp_path, monkeypatch):
    import tendon_id.zoo.estimator as E

    first, second = two_models
    folder = tmp_path / "m"
    real = E._write_blob
    other = threading.Thread(target=second.save, args=(folder,))
    seen = {}

    def write_then_race(tmp, blob):
        real(tmp, blob)
        if not other.is_alive() and "started" not in seen:
            seen["started"] = True
            other.start()  # a second save into the same folder, between this save's two files
            time.sleep(0.5)
            seen["waiting"] = other.is_alive()

    monkeypatch.setattr(E, "_write_blob", write_then_race)
    first.save(folder)
    other.join(timeout=30)
    assert seen["waiting"], "the second writer did not wait for the first"
    doc = json.loads((folder / "model.json").read_text())
    assert doc["model"] == second.name  # the last writer's pair, whole
    assert load(folder).name == second.name  # and it loads: its arrays are the ones model.json records


def test_concurrent_csv_writers_leave_one_writers_data_and_metadata(tmp_path, monkeypatch):
    import tendon_id.data.io as io
    from tendon_id.datasets import load as simulate

    a = simulate("snake12-paper", protocol="posterior-3", frames=200, seed=1)
    b = simulate("snake12-paper", protocol="posterior-3", frames=200, seed=2)
    path = tmp_path / "x.csv"
    real = io.atomic_write_all
    other = threading.Thread(target=b.write, args=(path,))
    seen = {}

    def write_then_race(writes):
        (side, write_side), rest = writes[0], writes[1:]

        def sidecar_then_race(tmp):
            write_side(tmp)
            if "started" not in seen:  # the sidecar is written; the CSV is next
                seen["started"] = True
                other.start()
                time.sleep(0.5)
                seen["waiting"] = other.is_alive()

        return real([(side, sidecar_then_race), *rest])

    monkeypatch.setattr(io, "atomic_write_all", write_then_race)
    a.write(path)
    other.join(timeout=60)
    assert seen["waiting"], "the second writer did not wait for the first"
    back = Recording.read(path)
    assert back.meta["seed"] == 2
    np.testing.assert_array_equal(back.actuator, b.actuator)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.csv", "x.json"]  # no temporary file left
