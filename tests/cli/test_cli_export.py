"""``tendon-id export``: the folder it writes, the checks it makes before any work, one line and exit 2 on bad input."""

import json

import pytest
from cli_helpers import run

from tendon_id.cli import main


@pytest.fixture(scope="module")
def model(recording, tmp_path_factory):
    folder = tmp_path_factory.mktemp("model") / "nonsmooth"
    argv = ["fit", "capstan-nonsmooth", "--data", str(recording), "--set", "n_starts=1", "--set", "maxeval=60"]
    assert main([*argv, "--out", str(folder)]) == 0
    return folder


@pytest.mark.parametrize("fmt, files", [("onnx", ["export.json", "model.onnx"]), ("c", ["export.json", "m.c", "m.h"])])
def test_export_writes_the_folder(model, tmp_path, capsys, fmt, files):
    out = tmp_path / "exported"
    code, stdout, err = run(capsys, "export", model, "--format", fmt, "--prefix", "m", "--out", out, "--json", "-")
    assert code == 0, err
    doc = json.loads(stdout)
    assert doc == {"model": "capstan-nonsmooth", "format": fmt, "out": str(out), "files": files}
    assert sorted(p.name for p in out.iterdir()) == files
    manifest = json.loads((out / "export.json").read_text())
    assert manifest["format"] == fmt and manifest["model"] == "capstan-nonsmooth" and manifest["n_modules"] == 12
    assert f"exported capstan-nonsmooth ({fmt})" in err
    # Exported again over itself: the earlier export is replaced whole, nothing left behind beside it.
    (out / "stale.txt").write_text("from an earlier export")
    assert main(["export", str(model), "--format", fmt, "--prefix", "m", "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == files
    assert [p.name for p in tmp_path.iterdir()] == ["exported"]


@pytest.mark.parametrize(
    "args, message",
    [
        (["--format", "tflite"], "--format: unknown export format 'tflite'; known: onnx, c"),
        (["--format", "c", "--prefix", "2fast"], "--prefix: must be a C identifier"),
    ],
)
def test_bad_options_exit_2_before_the_model_is_read(tmp_path, capsys, args, message):
    never = tmp_path / "never-read"  # were the model read first, the error would name it
    code, out, err = run(capsys, "export", never, *args, "--out", tmp_path / "out")
    assert code == 2 and message in err and "never-read" not in err and "Traceback" not in err
    assert err.count("\n") == 1 and out == "" and not (tmp_path / "out").exists()


def test_a_folder_of_other_files_is_never_touched(model, tmp_path, capsys):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    code, _, err = run(capsys, "export", model, "--format", "c", "--out", mine)
    assert code == 2 and "--out" in err and "not an export" in err
    assert [p.name for p in mine.iterdir()] == ["notes.txt"]


def test_a_model_that_cannot_be_exported_exits_2_naming_what_can(recording, tmp_path, capsys):
    folder = tmp_path / "proximal"
    assert main(["fit", "proximal", "--data", str(recording), "--out", str(folder)]) == 0
    capsys.readouterr()
    code, out, err = run(capsys, "export", folder, "--format", "onnx", "--out", tmp_path / "out")
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert "'proximal' cannot be exported" in err and "pg-chtc" in err and "capstan-nonsmooth" in err
    assert "formats onnx and c" in err and not (tmp_path / "out").exists()


def test_a_folder_without_a_model_exits_2(tmp_path, capsys):
    code, _, err = run(capsys, "export", tmp_path, "--format", "c", "--out", tmp_path / "out")
    assert code == 2 and "no model.json" in err


def test_the_help_lists_what_the_exporter_takes():
    from tendon_id.cli import deploy
    from tendon_id.export import EXPORTED_MODELS, FORMATS

    assert deploy.EXPORTED == ", ".join(EXPORTED_MODELS) and deploy.FORMATS == FORMATS
