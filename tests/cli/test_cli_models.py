"""fit / evaluate / calibrate / benchmark from the command line (docs/cli.rst JSON shapes)."""

import json

import pytest
from cli_helpers import run


def test_fit_then_evaluate_json(recording, tmp_path, capsys):
    code, out, err = run(
        capsys,
        "fit",
        "capstan-contact",
        "--data",
        str(recording),
        "--set",
        "tying=per-guide",
        "--out",
        str(tmp_path / "m"),
    )
    assert code == 0, err
    code, out, err = run(capsys, "evaluate", "--model", str(tmp_path / "m"), "--data", str(recording), "--json", "-")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["model"] == "capstan-contact" and doc["frames"] == 600
    assert set(doc["terminal"]) >= {"rmse", "r2", "max_error"}
    assert set(doc["joints"]) >= {"overall", "per_joint"} and len(doc["joints"]["per_joint"]) == 12
    code, out, _ = run(capsys, "evaluate", "--model", str(tmp_path / "m"), "--data", str(recording))
    assert code == 0 and "terminal joint" in out and "joint 12" in out


def test_calibrate_writes_the_documented_files(recording, tmp_path, capsys):
    code, out, err = run(
        capsys,
        "calibrate",
        "--data",
        str(recording),
        "--model",
        "capstan-simple",
        "--posterior",
        "--out",
        str(tmp_path / "c"),
    )
    assert code == 0, err
    cal = json.loads((tmp_path / "c" / "calibration.json").read_text())
    assert cal["model"] == "capstan-simple" and cal["tying"] == "tied"
    assert len(cal["A"]) == len(cal["B"]) == len(cal["mu0"]) == 3
    assert all(b >= abs(a) for a, b in zip(cal["A"], cal["B"]))
    post = json.loads((tmp_path / "c" / "posterior.json").read_text())
    assert set(post) >= {"parameters", "tau", "seconds"}
    assert set(post["parameters"]["A_1"]) >= {"mean", "sd", "q2.5", "q97.5", "ess", "rhat"}
    assert (tmp_path / "c" / "corner.png").stat().st_size > 1000


def test_calibrate_per_guide_shapes(recording, tmp_path, capsys):
    code, _, err = run(
        capsys,
        "calibrate",
        "--data",
        str(recording),
        "--model",
        "capstan-contact",
        "--tying",
        "per-guide",
        "--out",
        str(tmp_path / "c"),
    )
    assert code == 0, err
    cal = json.loads((tmp_path / "c" / "calibration.json").read_text())
    assert len(cal["A"]) == 11 and all(len(row) == 3 for row in cal["A"])


def test_benchmark_table1_json(tmp_path, capsys):
    code, out, err = run(capsys, "benchmark", "table1", "--repeats", "1", "--json", str(tmp_path / "t1.json"))
    assert code == 0, err
    doc = json.loads((tmp_path / "t1.json").read_text())
    assert doc["benchmark"] == "table1" and doc["preset"] == "fast" and doc["seconds"] > 0
    methods = [r["method"] for r in doc["rows"]]
    assert methods == [
        "proximal",
        "capstan-simple",
        "capstan-contact",
        "capstan-nonsmooth",
        "transformer",
        "lstm",
        "mlp",
        "pg-chtc",
    ]
    for r in doc["rows"]:
        assert r["protocol"] == "single-passage" and set(r["terminal"]) >= {"rmse", "r2", "max_error"}
    assert "capstan-nonsmooth" in out


@pytest.mark.slow
def test_benchmark_table2_json(tmp_path, capsys):
    code, out, err = run(capsys, "benchmark", "table2", "--json", str(tmp_path / "t2.json"))
    assert code == 0, err
    doc = json.loads((tmp_path / "t2.json").read_text())
    protocols = {(r["method"], r["protocol"]) for r in doc["rows"]}
    for m in ("proximal", "capstan-nonsmooth"):
        for p in ("posterior-3", "posterior-6", "planned-paths", "overall"):
            assert (m, p) in protocols
    assert all(r["joints"] is not None for r in doc["rows"])


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["fit", "capstan-simple", "--set", "nokey", "--out", "m"], "key=value"),
        (["evaluate", "--model", "nowhere", "--data", "x.parquet"], "no model.json"),
        (["benchmark", "table9"], "unknown benchmark"),
        (["benchmark", "table1", "--preset", "huge"], "unknown preset"),
        (["calibrate", "--model", "capstan-simple", "--out", "c"], "at least one recording"),
        (["benchmark", "table1", "--out", "page.html"], "--out: the table1 benchmark writes no page"),
        (["benchmark", "table3", "--out", "page.txt"], "the page is an HTML file"),
        (["benchmark", "table3", "--repeats", "0"], "--repeats: must be at least 1"),
    ],
)
def test_model_commands_bad_input_exit_2(tmp_path, monkeypatch, capsys, argv, needle):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, *argv)
    assert code == 2 and needle in err and "Traceback" not in err


def test_fit_prints_the_guard_and_warns_plainly_when_the_cascade_is_worse(recording, tmp_path, capsys):
    """A tiny PG-CHTC on 600 frames is worse than its calibrated prior: the CLI says so, in words, on stderr."""
    code, out, err = run(
        capsys, "fit", "pg-chtc", "--data", str(recording), "--set", "preset=tiny", "--out", str(tmp_path / "m")
    )
    assert code == 0, err
    assert "validation terminal RMSE" in out and "for its calibrated prior capstan-nonsmooth" in out
    own = [line for line in err.splitlines() if not line.startswith("tendon-id: ")]  # progress lines aside
    assert own[0].startswith("WARNING: the learned cascade is worse than its prior capstan-nonsmooth"), err
    assert "PriorGuardWarning" not in err and "Traceback" not in err
    code, out, err = run(capsys, "evaluate", "--model", str(tmp_path / "m"), "--data", str(recording))
    assert code == 0 and "for its calibrated prior" in out and "WARNING" in err
    code, out, err = run(
        capsys,
        "fit",
        "pg-chtc",
        "--data",
        str(recording),
        "--set",
        "preset=tiny",
        "--set",
        "fallback=true",
        "--out",
        str(tmp_path / "f"),
    )
    assert code == 0 and "it predicts with capstan-nonsmooth" in err
