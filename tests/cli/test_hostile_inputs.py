"""Issue 42's hostile inputs: each exits 2 with one line that says what is wrong (or runs, and warns), leaving nothing.

The cases live in ``tests/hostile_cases.py``, which ``perf/attack_table.py`` also runs (before and
after, as processes) for the table of the issue's note.
"""

import json
import os
import sys
from pathlib import Path

import pytest

from tendon_id.cli import main

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from hostile_cases import CASES, prepare  # noqa: E402


def _run_in(capsys, argv, cwd):
    here = os.getcwd()
    os.chdir(cwd)
    try:
        code = main([str(a) for a in argv])
    finally:
        os.chdir(here)
    out = capsys.readouterr()
    return code, out.err


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    folder = tmp_path_factory.mktemp("hostile") / "base"

    def run(argv, cwd):
        here = os.getcwd()
        os.chdir(cwd)
        try:
            code = main(argv)
        finally:
            os.chdir(here)
        return {"code": code, "stderr": ""}

    prepare(run, folder)
    return folder


@pytest.mark.parametrize("case", CASES, ids=[f"{c.id} {c.what}" for c in CASES])
def test_a_hostile_input_exits_2_with_one_accurate_line(base, tmp_path, capsys, case):
    capsys.readouterr()
    argv = case.setup(base, tmp_path)
    code, err = _run_in(capsys, argv, tmp_path)
    assert code == case.code, err
    assert "Traceback" not in err and "internal error" not in err, err
    errors = [line for line in err.splitlines() if line.startswith("tendon-id: error:") or line.startswith("Error:")]
    assert len(errors) == (1 if case.code else 0), err
    assert case.needle and case.needle in err, err  # a case that runs says why it is doubtful, as a warning
    if case.after is not None:  # nothing left behind: no output folder, no calibration.json
        left = case.after(tmp_path)
        assert left.endswith("absent") or left.startswith("no "), left


def test_the_json_written_is_standard_json_with_null_for_an_undefined_value(tmp_path):
    from tendon_id.atomic import json_text

    text = json_text({"r2": float("nan"), "rmse": [1.0, float("inf")], "nested": {"x": float("-inf")}})
    assert json.loads(text, parse_constant=lambda c: pytest.fail(f"non-standard token {c}")) == {
        "r2": None,
        "rmse": [1.0, None],
        "nested": {"x": None},
    }


def test_a_calibration_that_comes_out_nan_is_an_error_naming_its_data_and_writes_nothing(tmp_path, monkeypatch, capsys):
    from hostile_cases import MAPPING, bench_csv

    import tendon_id.zoo.passage.model as P

    real = P.PassageCapstan.fit

    def diverge(self, data):  # a fit whose optimum is NaN, however the data made it so
        real(self, data)
        self.theta_ = {**self.theta_, "gain": float("nan")}
        return self

    monkeypatch.setattr(P.PassageCapstan, "fit", diverge)
    bench_csv(tmp_path / "b.csv")
    (tmp_path / "b.toml").write_text(MAPPING)
    out = tmp_path / "o"
    argv = ["calibrate", "--model", "passage-capstan", "--mapping", "b.toml", "--data", "b.csv", "--out", str(out)]
    code, err = _run_in(capsys, argv, tmp_path)
    assert code == 2, err
    assert "passage-capstan on b.csv gave a non-finite" in err and "theta.gain" in err, err
    assert not out.exists()


def test_a_fit_that_comes_out_nan_is_never_saved(tmp_path):
    from tendon_id.errors import NonFiniteResult
    from tendon_id.zoo import make

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from passage_data import tendon_passage

    model = make("passage-capstan").fit(tendon_passage(0))
    model.theta_ = {**model.theta_, "phi": float("inf")}
    with pytest.raises(NonFiniteResult, match="non-finite"):
        model.check_finite_fit("run0")
    with pytest.raises(NonFiniteResult):
        model.save(tmp_path / "m")  # nothing written: the folder is not even made
    assert not (tmp_path / "m").exists()
