"""The command line: byte-identical simulation, info, and exit code 2 with a one-line reason on bad input."""

import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from cli_helpers import run
from test_data import BAD, make_recording  # noqa: E402  (the bad inputs of docs/guide/data.rst)


def test_simulate_twice_gives_identical_bytes_and_info_reports_it(tmp_path, capsys):
    a, b = tmp_path / "x.parquet", tmp_path / "y.parquet"
    args = ["simulate", "--recipe", "snake12-paper", "--protocol", "posterior-3", "--seed", "7", "--frames", "800"]
    assert run(capsys, *args, "--out", str(a))[0] == 0
    assert run(capsys, *args, "--out", str(b))[0] == 0
    assert a.read_bytes() == b.read_bytes()
    code, out, _ = run(capsys, "info", str(a))
    assert code == 0
    assert "modules       12" in out
    assert "frames        800" in out
    assert "trajectories  4" in out
    assert "intermediate joint sides: yes (joints 1..11)" in out
    code, out, _ = run(capsys, "info", str(a), "--json")
    s = json.loads(out)
    assert s["n_modules"] == 12 and s["n_frames"] == 800 and s["n_trajectories"] == 4
    assert s["truth"]["intermediate"] is True and s["truth"]["terminal"] is True


def test_simulate_csv_with_effects_override(tmp_path, capsys):
    out = tmp_path / "sp.csv"
    code, msg, err = run(
        capsys,
        "simulate",
        "--protocol",
        "single-passage",
        "--effects",
        "stick_slip,contact",
        "--frames",
        "300",
        "--out",
        str(out),
    )
    assert code == 0, err
    assert out.is_file() and out.with_suffix(".json").is_file()
    meta = json.loads(out.with_suffix(".json").read_text())
    assert meta["n_modules"] == 2 and meta["effects"] == ["contact", "stick_slip"]


def test_info_without_truth_says_so(tmp_path, capsys):
    rec = make_recording(truth=False)
    path = rec.write(tmp_path / "tip_only.parquet")
    code, out, _ = run(capsys, "info", str(path))
    assert code == 0 and "intermediate joint sides: no" in out


@pytest.mark.parametrize("case", BAD, ids=[b[0] for b in BAD])
def test_every_bad_input_exits_2_naming_file_column_and_row(tmp_path, capsys, case):
    _, edit, column, row, text = case
    rec = make_recording()
    path = tmp_path / "bad.csv"
    rec.write(path)
    edit(rec.frame).to_csv(path, index=False)
    code, out, err = run(capsys, "info", str(path))
    assert code == 2
    assert out == ""
    line = err.strip()
    assert "\n" not in line and "Traceback" not in err
    assert "bad.csv" in line and f"'{column}'" in line and text in line
    if row is not None:
        assert f"row {row}" in line


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["simulate", "--protocol", "posterior-9", "--out", "x.parquet"], "unknown protocol"),
        (["simulate", "--effects", "magic", "--out", "x.parquet"], "unknown effect"),
        (["simulate", "--recipe", "no-such-recipe", "--out", "x.parquet"], "no recipe named"),
        (["simulate", "--out", "x.txt"], "must end in .parquet or .csv"),
        (["simulate", "--frames", "1", "--out", "x.parquet"], "frames"),
        (["info", "does-not-exist.parquet"], "no such file"),
        (["simulate", "--no-such-option"], "No such option"),
    ],
)
def test_bad_options_exit_2_with_one_line(tmp_path, capsys, monkeypatch, argv, needle):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, *argv)
    assert code == 2
    assert needle in err and "Traceback" not in err
    assert not list(tmp_path.glob("x.*"))  # nothing half-written


def test_help_exits_0(capsys):
    code, out, _ = run(capsys, "--help")
    assert code == 0 and "simulate" in out and "info" in out and "demo" in out


def test_bad_recipe_file_exits_2(tmp_path, capsys):
    bad = tmp_path / "r.toml"
    bad.write_text('name = "r"\n[robot]\nn_modules = 1\n')
    code, _, err = run(capsys, "simulate", "--recipe", str(bad), "--out", str(tmp_path / "x.parquet"))
    assert code == 2 and "n_modules" in err and "r.toml" in err


def test_info_reads_a_csv_written_by_a_separate_program(tmp_path, capsys):
    # Written with the csv module alone, following docs/guide/data.rst, with no sidecar metadata.
    import csv

    n = 2
    cols = ["trajectory", "t"] + [f"theta_{k}_{a}" for k in (1, 2) for a in "xy"]
    cols += [f"tension_act_{j}_{i}" for j in (1, 2) for i in (1, 2, 3)] + [f"tension_joint_{n}_{i}" for i in (1, 2, 3)]
    path = tmp_path / "bench_log.csv"
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols + ["my_own_signal"])
        for r in range(30):
            traj = "run-a" if r < 15 else "run-b"
            t = 0.1 * (r % 15)
            w.writerow([traj, f"{t:.1f}", 0.01 * r, -0.02, 0.03, 0.001 * r] + [100 + r] * 6 + [80 + r] * 3 + [r])
    code, out, err = run(capsys, "info", str(path))
    assert code == 0, err
    assert "modules       2" in out and "frames        30" in out and "trajectories  2" in out
    assert "intermediate joint sides: no" in out
