"""No lost work (issue 19, item 3): long commands refuse a bad output before working, a Ctrl-C leaves
only whole files and says where it stopped (exit 130), and a NaN loss in training is told, not fatal."""

import json
import os
import re
import signal
import sys
from pathlib import Path

import numpy as np
import pytest

from tendon_id.atomic import check_writable, hold_interrupt, write_json_atomic
from tendon_id.data import Recording
from tendon_id.errors import ConfigError
from tendon_id.progress import progress_bar

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "learners"))
from cli_helpers import files as _files
from cli_helpers import run
from test_nonfinite import poison_stage2  # noqa: E402  (the NaN injected in PG-CHTC's stage 2)


def _never(*_args, **_kwargs):
    raise AssertionError("the long work started before the output was checked")


@pytest.fixture
def ctrl_c_raises():
    """Ctrl-C raises KeyboardInterrupt, as in a terminal, for tests that send a real SIGINT.

    A process started in the background by a shell without job control inherits SIGINT ignored,
    and Python then leaves it ignored; these tests are about the terminal's case.
    """
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


# ---- 1. outputs, inputs and extras are checked before the long part -------------------------------


@pytest.mark.parametrize(
    "argv, patch, needle",
    [
        (["fit", "pg-chtc", "--data", "{rec}", "--out", "{blocker}/m"], "tendon_id.zoo.make", "is a file"),
        (["fit", "capstan-simple", "--data", "{rec}", "--out", "{blocker}"], "tendon_id.zoo.make", "not a folder"),
        (["calibrate", "--data", "{rec}", "--posterior", "--out", "{blocker}/c"],
         "tendon_id.report.calibration.run_calibration", "is a file"),
        (["identifiability", "--data", "{rec}", "--out", "{blocker}/r.html"],
         "tendon_id.identifiability.analyse", "is a file"),
        (["identifiability", "--data", "{rec}", "--out", "r.html", "--json", "{blocker}/r.json"],
         "tendon_id.identifiability.analyse", "is a file"),
        (["identifiability", "--data", "{rec}", "--out", "r.html", "--json", "r.txt"],
         "tendon_id.identifiability.analyse", "must end in .json"),
        (["identifiability", "--data", "{one}", "--out", "r.html", "--learned"],
         "tendon_id.identifiability.analyse", "at least two trajectories"),
        (["diagnose", "--data", "{rec}", "--base", "capstan-simple", "--out", "{blocker}/d.html"],
         "tendon_id.diagnosis.diagnose", "is a file"),
        (["benchmark", "table2", "--json", "{blocker}/t.json"], "tendon_id.benchmarks.registry.Benchmark.__call__",
         "is a file"),
        (["benchmark", "table2", "--json", "t.txt"], "tendon_id.benchmarks.registry.Benchmark.__call__",
         "must end in .json"),
        (["benchmark", "regimes", "--out", "{blocker}/p.html"], "tendon_id.benchmarks.registry.Benchmark.__call__",
         "is a file"),
        (["benchmark", "sweep", "--backend", "no-such-backend"], "tendon_id.benchmarks.registry.Benchmark.__call__",
         "joblib backend"),
        (["benchmark", "table1", "--recipe", "no-such-recipe"], "tendon_id.benchmarks.registry.Benchmark.__call__",
         "no-such-recipe"),
        (["demo", "--out", "{blocker}/demo"], "tendon_id.demo.run_demo", "is a file"),
        (["simulate", "--out", "{blocker}/x.parquet"], "tendon_id.sim.simulate", "is a file"),
    ],
)  # fmt: skip
def test_a_bad_output_or_option_fails_before_the_long_work(
    recording, tmp_path, monkeypatch, capsys, argv, patch, needle
):
    monkeypatch.chdir(tmp_path)
    blocker = tmp_path / "blocker"
    blocker.write_text("a regular file, not a folder")
    one = tmp_path / "one.parquet"
    rec = Recording.read(recording)
    rec.select(rec.trajectories[:1]).write(one)
    monkeypatch.setattr(patch, _never)
    argv = [a.format(rec=recording, blocker=blocker, one=one) for a in argv]
    code, _, err = run(capsys, *argv)
    assert code == 2, err
    assert needle in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert err.startswith("tendon-id: error: ")


def test_check_writable_accepts_missing_folders_and_refuses_folders_as_files(tmp_path):
    assert check_writable(tmp_path / "new" / "deeper" / "r.html", "--out", suffixes=(".html",))
    assert check_writable(tmp_path / "new-folder", "--out", folder=True)
    with pytest.raises(ConfigError, match="is a folder, not a file"):
        check_writable(tmp_path, "--json")
    if os.geteuid() != 0:  # root may write anywhere
        locked = tmp_path / "locked"
        locked.mkdir(mode=0o500)
        with pytest.raises(ConfigError, match="permission denied"):
            check_writable(locked / "r.json", "--json")


# ---- 2. Ctrl-C: whole files only, where it stopped, exit 130 ---------------------------------------


def _interrupt_at(n, desc, unit):
    """A long function that goes through ``desc``'s loop and is interrupted at item ``n``."""

    def long(*_args, **_kwargs):
        for i in progress_bar(range(9), desc=desc, unit=unit, enable=False):
            if i + 1 == n:
                raise KeyboardInterrupt

    return long


# A stage's or a loop's plain line (tendon_id.progress), which a test's captured stderr also gets.
PROGRESS_LINE = re.compile(r"tendon-id: .*( \.\.\.| done in \d.*| \d+( of \d+)?)")


def _assert_interrupted(code, err, *needles):
    assert code == 130, err
    lines = [line for line in err.strip().splitlines() if not PROGRESS_LINE.fullmatch(line)]
    assert "Traceback" not in err and len(lines) == 1, err
    assert lines[0].startswith("tendon-id: interrupted during ")
    for needle in needles:
        assert needle in lines[0], err


def test_ctrl_c_in_a_benchmark_writes_nothing_and_says_which_row(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr("tendon_id.benchmarks.registry.Benchmark.__call__", _interrupt_at(4, "table2", "row"))
    code, _, err = run(capsys, "benchmark", "table2", "--json", str(tmp_path / "t2.json"))
    _assert_interrupted(code, err, "benchmark table2, table2 row 4 of 9", "nothing written")
    assert _files(tmp_path) == []


def test_ctrl_c_in_identifiability_and_diagnose_writes_no_report(recording, tmp_path, monkeypatch, capsys):
    monkeypatch.setattr("tendon_id.identifiability.analyse", _interrupt_at(3, "identifiability", "step"))
    out = tmp_path / "out"
    code, _, err = run(
        capsys, "identifiability", "--data", str(recording), "--out", str(out / "r.html"), "--json", str(out / "r.json")
    )
    _assert_interrupted(code, err, "identifiability step 3 of 9", "nothing written")
    monkeypatch.setattr("tendon_id.diagnosis.diagnose", _interrupt_at(7, "refits", "refit"))
    code, _, err = run(capsys, "diagnose", "--data", str(recording), "--base", "capstan-simple",
                       "--out", str(out / "d.html"))  # fmt: skip
    _assert_interrupted(code, err, "diagnose, refits refit 7 of 9", "nothing written")
    assert not out.exists() or _files(out) == []


def test_ctrl_c_while_writing_a_file_leaves_no_part_of_it(recording, tmp_path, monkeypatch, capsys):
    """Interrupted halfway through arrays.npz: no arrays.npz, no temporary file, no model.json."""
    import tendon_id.zoo.estimator as E

    def half_then_interrupt(tmp, blob):
        with open(tmp, "wb") as fh:
            fh.write(b"PK\x03\x04 half of a zip")
        raise KeyboardInterrupt

    monkeypatch.setattr(E, "_write_blob", half_then_interrupt)
    out = tmp_path / "m"
    code, _, err = run(capsys, "fit", "capstan-simple", "--data", str(recording), "--out", str(out))
    _assert_interrupted(code, err, "writing the model", "nothing written")
    assert _files(out) == []


def test_a_ctrl_c_while_the_model_is_written_is_held_until_both_files_are_whole(
    recording, tmp_path, monkeypatch, capsys, ctrl_c_raises
):
    import tendon_id.zoo.estimator as E

    real = E._write_blob

    def savez_then_signal(tmp, blob):
        real(tmp, blob)
        signal.raise_signal(signal.SIGINT)  # a real Ctrl-C, between arrays.npz and model.json

    monkeypatch.setattr(E, "_write_blob", savez_then_signal)
    out = tmp_path / "m"
    code, _, err = run(capsys, "fit", "capstan-simple", "--data", str(recording), "--out", str(out))
    _assert_interrupted(code, err, "writing the model", "wrote only", "arrays.npz", "model.json")
    assert _files(out) == ["arrays.npz", "model.json"]
    assert json.loads((out / "model.json").read_text())["model"] == "capstan-simple"


def test_ctrl_c_in_the_posterior_keeps_the_calibration_and_names_it(recording, tmp_path, monkeypatch, capsys):
    import tendon_id.report.calibration as C

    def sampler(*_args, **_kwargs):
        for i in progress_bar(range(20), desc="posterior", unit="chunk", enable=False):
            if i == 5:
                raise KeyboardInterrupt

    monkeypatch.setattr(C, "sample_posterior", sampler)
    out = tmp_path / "c"
    code, _, err = run(capsys, "calibrate", "--data", str(recording), "--model", "capstan-simple", "--posterior",
                       "--out", str(out))  # fmt: skip
    _assert_interrupted(code, err, "calibrate capstan-simple and its posterior, posterior chunk 6 of 20")
    assert "wrote only" in err and "calibration.json" in err
    assert "calibration.json" in _files(out) and "posterior.json" not in _files(out)
    assert not [f for f in _files(out) if f.endswith(".tmp")]
    json.loads((out / "calibration.json").read_text())  # whole


def test_hold_interrupt_finishes_the_block_then_raises(ctrl_c_raises):
    done = []
    with pytest.raises(KeyboardInterrupt):
        with hold_interrupt():
            signal.raise_signal(signal.SIGINT)
            done.append("the rest of the block")
    assert done == ["the rest of the block"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_hold_interrupt_keeps_an_ignored_ctrl_c_ignored():
    """Where SIGINT is ignored (a background job), a SIGINT inside the block is not turned into an error."""
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        done = []
        with hold_interrupt():
            signal.raise_signal(signal.SIGINT)
            done.append("the rest of the block")
        assert done == ["the rest of the block"]
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)


def test_an_interrupted_atomic_write_removes_its_temporary_file(tmp_path):
    target = tmp_path / "r.json"
    write_json_atomic(target, {"old": 1})

    class Boom:
        def __float__(self):
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_json_atomic(target, {"new": Boom()})
    assert _files(tmp_path) == ["r.json"] and json.loads(target.read_text()) == {"old": 1}


# ---- 3. a NaN loss in training is told on stderr, and the model is kept ----------------------------


def test_fit_stopped_by_a_nan_loss_saves_the_best_weights_and_says_so(recording, tmp_path, monkeypatch, capsys):
    poison_stage2(monkeypatch, bad_epoch=2)
    out = tmp_path / "m"
    prior = json.dumps({"A": [0.1] * 3, "B": [0.2] * 3})
    code, _, err = run(capsys, "fit", "pg-chtc", "--data", str(recording), "--set", "preset=tiny", "--set",
                       f"prior={prior}", "--out", str(out))  # fmt: skip
    assert code == 0, err
    warning = [line for line in err.splitlines() if line.startswith("tendon-id: warning: ")]
    assert len(warning) == 1 and "stage 2 (g_phi): the loss became nan at epoch 2" in warning[0]
    assert "kept the weights of epoch 1" in warning[0] and "Traceback" not in err
    doc = json.loads((out / "model.json").read_text())
    assert doc["state"]["history"]["stage2"][-1]["non_finite"] is True
    from tendon_id import zoo

    assert np.isfinite(zoo.load(out).predict(Recording.read(recording))).all()
