"""``tendon-id calibrate --each``: one result per file, bad files named before any work, and the exit code
of a fleet where a file is refused or fails (issue 42, deliver 6)."""

import json
import shutil

import pytest
from cli_helpers import files, run

import tendon_id.report.fleet as fleet_module
from tendon_id.errors import ConfigError


@pytest.fixture
def two(recording, tmp_path):
    """The module's recording twice, under one stem in two folders."""
    (tmp_path / "day2").mkdir()
    shutil.copy(recording, tmp_path / "day2" / recording.name)
    return [recording, tmp_path / "day2" / recording.name]


def test_each_file_gets_its_folder_and_the_fleet_its_summary(two, tmp_path, capsys):
    # one job: two workers give the same bytes (tests/test_fleet.py), and starting them costs seconds
    out = tmp_path / "fleet"
    argv = ["calibrate", "--model", "capstan-simple", "--data", two[0], "--data", two[1], "--each"]
    code, stdout, err = run(capsys, *argv, "--out", out, "--json", "-")
    assert code == 0, err
    assert files(out) == [
        "fleet.json",
        "p6-2/calibration.json",
        "p6-2/model/arrays.npz",
        "p6-2/model/model.json",
        "p6/calibration.json",
        "p6/model/arrays.npz",
        "p6/model/model.json",
    ]
    doc = json.loads(stdout)  # --json -: the JSON alone on stdout
    assert doc["fleet"] == json.loads((out / "fleet.json").read_text())
    assert doc["files"] == [str(out / "p6"), str(out / "p6-2"), str(out / "fleet.json")]
    assert [e["file"] for e in doc["fleet"]["entries"]] == [str(p) for p in two]
    assert f"-> {out / 'p6-2'}" in err and "calibrated 2 of 2 files" in err
    assert (out / "p6" / "model" / "arrays.npz").read_bytes() == (out / "p6-2" / "model" / "arrays.npz").read_bytes()


def test_help_shows_each_and_jobs(capsys):
    code, out, _ = run(capsys, "calibrate", "--help")
    assert code == 0 and "--each" in out and "--jobs" in out


@pytest.mark.parametrize(
    "extra, needle",
    [
        (["--each", "--posterior"], "--posterior is not taken with --each"),
        (["--jobs", "2"], "--jobs: taken with --each only"),
        (["--each", "--jobs", "0"], "--jobs: must be a number of workers"),
    ],
)
def test_options_that_do_not_go_together_exit_2_before_any_work(
    recording, tmp_path, capsys, monkeypatch, extra, needle
):
    monkeypatch.setattr(fleet_module, "calibrate_one", pytest.fail)
    code, _, err = run(capsys, "calibrate", "--data", recording, *extra, "--out", tmp_path / "o")
    assert code == 2 and needle in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "o").exists()


def test_a_bad_file_is_named_with_exit_2_before_any_fit(recording, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(fleet_module, "calibrate_one", pytest.fail)  # no job may start
    bad = tmp_path / "broken.parquet"
    bad.write_bytes(b"PAR1 cut off")
    code, out, err = run(capsys, "calibrate", "--data", recording, "--data", bad, "--each", "--out", tmp_path / "o")
    assert code == 2 and err.startswith(f"tendon-id: error: {bad}") and len(err.strip().splitlines()) == 1, err
    assert "Traceback" not in err and not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    "raised, code, status",
    [(ConfigError("too few frames to calibrate"), 2, "refused"), (ZeroDivisionError("oops"), 1, "failed")],
)
def test_a_file_that_fails_at_fit_time_is_named_and_the_other_kept(
    two, tmp_path, capsys, monkeypatch, raised, code, status
):
    real = fleet_module.fit_calibration
    calls = []

    def fit(recordings, **kwargs):
        calls.append(1)
        if len(calls) == 2:  # the second file, in this process (one job)
            raise raised
        return real(recordings, **kwargs)

    monkeypatch.setattr(fleet_module, "fit_calibration", fit)
    out = tmp_path / "f"
    got, stdout, err = run(capsys, "calibrate", "--model", "capstan-simple", "--data", two[0], "--data", two[1],
                           "--each", "--out", out)  # fmt: skip
    assert got == code
    why = str(raised) if status == "refused" else "internal error: ZeroDivisionError: oops"
    assert err.strip().splitlines() == [f"tendon-id: error: {two[1]}: {why}"]  # one line per failing file
    assert f"{two[1]}: {status}, nothing written" in stdout and "calibrated 1 of 2 files" in stdout
    doc = json.loads((out / "fleet.json").read_text())
    assert [e["status"] for e in doc["entries"]] == ["ok", status] and doc[status] == 1
    assert files(out) == ["fleet.json", "p6/calibration.json", "p6/model/arrays.npz", "p6/model/model.json"]


def test_ctrl_c_keeps_the_files_already_calibrated_and_names_them(two, tmp_path, capsys, monkeypatch):
    real = fleet_module.fit_calibration
    calls = []

    def fit(recordings, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(recordings, **kwargs)

    monkeypatch.setattr(fleet_module, "fit_calibration", fit)
    out = tmp_path / "f"
    code, _, err = run(capsys, "calibrate", "--model", "capstan-simple", "--data", two[0], "--data", two[1],
                       "--each", "--out", out)  # fmt: skip
    assert code == 130 and "interrupted during calibrate capstan-simple on each of 2 files, file 1 of 2" in err, err
    assert f"wrote only {out / 'p6' / 'calibration.json'}" in err
    assert files(out) == ["p6/calibration.json", "p6/model/arrays.npz", "p6/model/model.json"]  # whole, no fleet.json
