"""One CLI convention (issue 37): ``--json PATH`` writes, ``--json -`` prints JSON alone on stdout; ``--version``;
``--help`` names values by metavars, not Python types; plain progress lines where stderr is not a terminal."""

import json
import re
import time
from pathlib import Path

import pytest
from cli_helpers import run

import tendon_id
from tendon_id import progress
from tendon_id.cli import main
from tendon_id.cli.app import bare_json

COMMANDS = [
    "simulate",
    "convert",
    "info",
    "fit",
    "evaluate",
    "calibrate",
    "export",
    "benchmark",
    "identifiability",
    "diagnose",
    "demo",
]
JSON_COMMANDS = COMMANDS  # every command takes --json PATH|-


@pytest.fixture(scope="module")
def model(recording, tmp_path_factory):
    folder = tmp_path_factory.mktemp("model") / "m"
    assert main(["fit", "capstan-simple", "--data", str(recording), "--out", str(folder)]) == 0
    return folder


# ---- --version and --help ---------------------------------------------------------------------------


def test_version_prints_the_version_and_exits_0(capsys):
    code, out, err = run(capsys, "--version")
    assert code == 0 and out == f"tendon-id {tendon_id.__version__}\n" and err == ""


@pytest.mark.parametrize("command", ["", *COMMANDS])
def test_help_names_values_by_metavars_and_shows_flags_bare(capsys, command):
    code, out, _ = run(capsys, *([command] if command else []), "--help")
    assert code == 0 and "--help" in out
    # typer >= 0.26 shows a Python type (<list[Path]>, <bool>, <path>) where a parameter has no metavar
    assert not re.search(r"<(list\[|bool|str|path|int|float|Path)", out), out
    if command in JSON_COMMANDS:
        assert re.search(r"--json\s+PATH", out), out


def test_bare_json_means_print():
    assert bare_json(["info", "f.parquet", "--json"]) == ["info", "f.parquet", "--json", "-"]
    assert bare_json(["evaluate", "--json", "--model", "m"]) == ["evaluate", "--json", "-", "--model", "m"]
    assert bare_json(["info", "--json", "-", "f"]) == ["info", "--json", "-", "f"]
    assert bare_json(["info", "--json", "s.json", "f"]) == ["info", "--json", "s.json", "f"]


# ---- --json PATH and --json - -------------------------------------------------------------------------


class _Result:
    """A result of the long work, as small as the command line needs."""

    def __init__(self, d):
        self.d = d

    def to_dict(self):
        return self.d

    def summary(self):
        return "the diagnosis summary"


def _page(result, out, json_path=None):
    assert json_path is None  # the command line writes the JSON itself, wherever --json says
    Path(out).write_text("<!DOCTYPE html>")
    return Path(out)


@pytest.fixture
def quick_work(monkeypatch):
    """The long work of benchmark, identifiability and diagnose replaced by a small result that also chatters
    on stdout as a library might: what is tested here is where the command line sends things."""

    def chatty(d):
        def work(*_args, **_kwargs):
            print("chatter from the library")
            return d

        return work

    ident = {
        "tied": {"rank": 6, "n_params": 6},
        "per_guide": {"rank": 24, "n_params": 66, "n_unidentifiable": 42},
        "advice": {"instrument_joint": 5, "excite_joints": [1, 2]},
        "summary": [{"tone": "warning", "text": "misspecified"}, {"tone": "verdict", "text": "rank 6/6"}],
        "nan": float("nan"),
    }
    monkeypatch.setattr("tendon_id.identifiability.analyse", chatty(_Result(ident)))
    monkeypatch.setattr("tendon_id.report.identifiability.write_report", _page)
    monkeypatch.setattr("tendon_id.diagnosis.diagnose", chatty(_Result({"base": "capstan-simple"})))
    monkeypatch.setattr("tendon_id.report.diagnosis.write_report", _page)
    table = {"benchmark": "table1", "preset": "fast", "rows": [], "seconds": 0.5, "r2": float("nan")}
    monkeypatch.setattr("tendon_id.benchmarks.registry.Benchmark.__call__", chatty(table))
    monkeypatch.setattr("tendon_id.benchmarks.registry.format_table", lambda result: "the benchmark table")


# command -> (its arguments, a check of its JSON, a line of its human output)
CASES = {
    "simulate": (
        ["simulate", "--protocol", "posterior-6", "--frames", "300", "--out", "{tmp}/s.parquet"],
        lambda d: d["n_frames"] == 300 and d["path"].endswith("s.parquet"),
        "300 frames",
    ),
    "fit": (
        ["fit", "capstan-simple", "--data", "{rec}", "--out", "{tmp}/m"],
        lambda d: d["model"] == "capstan-simple" and d["frames"] == 600,
        "fitted capstan-simple on 600 frames",
    ),
    "calibrate": (
        ["calibrate", "--data", "{rec}", "--model", "capstan-simple", "--out", "{tmp}/cal"],
        lambda d: d["files"][0].endswith("calibration.json") and d["calibration"],
        "calibration.json",
    ),
    "demo": (
        ["demo", "--no-models", "--frames", "300", "--out", "{tmp}/demo"],
        lambda d: d["summary"].endswith("summary.html") and d["pages"] == [d["summary"]],
        "summary.html",
    ),
    "info": (["info", "{rec}"], lambda d: d["n_frames"] == 600, "modules       12"),
    "convert": (
        [
            "convert",
            "--mapping",
            str(Path(__file__).with_name("identity.toml")),
            "--data",
            "{rec}",
            "--out",
            "{tmp}/c.parquet",
        ],
        lambda d: d["n_frames"] == 600 and d["path"].endswith("c.parquet"),
        "600 frames",
    ),
    "evaluate": (
        ["evaluate", "--model", "{model}", "--data", "{rec}"],
        lambda d: d["model"] == "capstan-simple" and set(d["terminal"]) >= {"rmse", "r2", "max_error"},
        "terminal joint",
    ),
    "export": (
        ["export", "{model}", "--format", "c", "--out", "{tmp}/exported"],
        lambda d: d["model"] == "capstan-simple" and d["files"] == ["export.json", "tendon_model.c", "tendon_model.h"],
        "exported capstan-simple (c)",
    ),
    "benchmark": (
        ["benchmark", "table1"],
        lambda d: d["benchmark"] == "table1" and d["r2"] is None,  # standard JSON: NaN is null
        "the benchmark table",
    ),
    "identifiability": (
        ["identifiability", "--data", "{rec}", "--out", "{tmp}/r.html"],
        lambda d: d["tied"]["rank"] == 6 and d["nan"] is None,  # standard JSON: NaN is null
        "tied: rank 6/6",
    ),
    "diagnose": (
        ["diagnose", "--data", "{rec}", "--base", "capstan-simple", "--out", "{tmp}/d.html"],
        lambda d: d["base"] == "capstan-simple",
        "the diagnosis summary",
    ),
}


def _argv(command, recording, model, tmp_path):
    return [a.format(rec=recording, model=model, tmp=tmp_path) for a in CASES[command][0]]


@pytest.mark.usefixtures("quick_work")
@pytest.mark.parametrize("command", JSON_COMMANDS)
def test_json_dash_prints_the_json_alone_on_stdout(recording, model, tmp_path, capsys, command):
    _, check, human = CASES[command]
    code, out, err = run(capsys, *_argv(command, recording, model, tmp_path), "--json", "-")
    assert code == 0, err
    assert check(json.loads(out))  # the whole of stdout is the JSON
    assert human in err  # the other lines moved to stderr
    assert not list(tmp_path.glob("*.json"))


@pytest.mark.usefixtures("quick_work")
@pytest.mark.parametrize("command", JSON_COMMANDS)
def test_json_path_writes_the_file_and_prints_as_without_it(recording, model, tmp_path, capsys, command):
    _, check, human = CASES[command]
    path = tmp_path / "out" / "result.json"
    code, out, err = run(capsys, *_argv(command, recording, model, tmp_path), "--json", path)
    assert code == 0, err
    assert check(json.loads(path.read_text()))
    assert human in out and f"{path}" in out
    assert "chatter" not in err


@pytest.mark.parametrize("command", ["info", "evaluate"])
def test_a_bare_json_still_prints(recording, model, tmp_path, capsys, command):
    """``info --json`` and ``evaluate --json`` printed JSON before ``--json`` took a value; they still do."""
    code, out, err = run(capsys, *_argv(command, recording, model, tmp_path), "--json")
    assert code == 0, err
    assert CASES[command][1](json.loads(out))


@pytest.mark.parametrize("command", JSON_COMMANDS)
def test_a_json_path_not_ending_in_json_exits_2(recording, model, tmp_path, capsys, command):
    code, out, err = run(capsys, *_argv(command, recording, model, tmp_path), "--json", tmp_path / "r.txt")
    assert code == 2 and "--json" in err and "must end in .json" in err and "Traceback" not in err
    assert out == "" and not (tmp_path / "r.txt").exists()


# ---- plain progress lines where stderr is not a terminal ----------------------------------------------


@pytest.fixture
def fresh_progress(monkeypatch):
    progress.reset()
    yield monkeypatch
    progress.reset()


def test_durations_read_plainly():
    assert [progress._duration(s) for s in (0.4, 12, 125, 3725)] == ["0 s", "12 s", "2 min 05 s", "1 h 02 min"]


def test_a_quick_stage_prints_nothing(fresh_progress, capsys):
    with progress.stage("quick"):
        pass
    assert capsys.readouterr().err == ""


def test_a_long_stage_prints_a_line_when_it_lasts_and_one_when_it_ends(fresh_progress, capsys):
    fresh_progress.setattr(progress, "ANNOUNCE_AFTER_S", 0.05)
    with progress.stage("simulate planned-paths"):
        time.sleep(0.3)
    first, done = capsys.readouterr().err.splitlines()
    assert first == "tendon-id: simulate planned-paths ..."
    assert re.fullmatch(r"tendon-id: simulate planned-paths done in \d s", done), done


def test_a_stage_left_by_an_error_says_no_done(fresh_progress, capsys):
    fresh_progress.setattr(progress, "ANNOUNCE_AFTER_S", 0.05)
    with pytest.raises(KeyboardInterrupt), progress.stage("fit pg-chtc"):
        time.sleep(0.3)
        raise KeyboardInterrupt
    assert capsys.readouterr().err == "tendon-id: fit pg-chtc ...\n"


def test_only_the_outermost_loop_of_a_stage_prints_its_position(fresh_progress, capsys):
    fresh_progress.setattr(progress, "ANNOUNCE_AFTER_S", 1e9)
    fresh_progress.setattr(progress, "LOOP_EVERY_S", 0.0)  # every step, to see which loops speak
    for _ in progress.progress_bar(range(2), desc="outside a stage"):
        pass
    with progress.stage("benchmark table2"):
        for _ in progress.progress_bar(range(2), desc="table2", unit="split"):
            for _ in progress.progress_bar(range(3), desc="methods"):
                pass
        for _ in progress.progress_bar(range(2), desc="quiet", enable=False):
            pass
    assert capsys.readouterr().err.splitlines() == [
        "tendon-id: benchmark table2, table2 split 1 of 2",
        "tendon-id: benchmark table2, table2 split 2 of 2",
    ]


def test_loop_lines_are_spaced(fresh_progress, capsys):
    fresh_progress.setattr(progress, "ANNOUNCE_AFTER_S", 1e9)
    with progress.stage("long"):
        for _ in progress.progress_bar(range(1000), desc="steps"):
            pass
    assert capsys.readouterr().err == ""  # well under LOOP_EVERY_S


def test_a_terminal_gets_no_plain_lines(fresh_progress, capsys):
    class Terminal:
        def isatty(self):
            return True

        def write(self, text):
            raise AssertionError(f"wrote {text!r} on a terminal")

        def flush(self):
            pass

    fresh_progress.setattr("sys.stderr", Terminal())
    fresh_progress.setattr(progress, "ANNOUNCE_AFTER_S", 0.0)
    with progress.stage("fit"):
        time.sleep(0.2)
        for _ in progress.progress_bar(range(2), desc="steps", enable=False):
            pass


def test_a_command_prints_its_stages_when_stderr_is_not_a_terminal(fresh_progress, tmp_path, capsys):
    fresh_progress.setattr(progress, "ANNOUNCE_AFTER_S", 0.0)
    out_file = tmp_path / "x.parquet"
    code, out, err = run(capsys, "simulate", "--frames", "2000", "--out", out_file)
    assert code == 0, err
    assert out == f"wrote {out_file}: 2000 frames, 10 trajectories, 12 modules\n"
    lines = err.splitlines()
    assert lines[:2] == ["tendon-id: simulate ...", lines[1]] and re.fullmatch(
        r"tendon-id: simulate done in \d+ s", lines[1]
    ), err
