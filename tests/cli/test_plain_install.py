"""A plain install: optional extras are reported before work starts, help texts come from the registries."""

import importlib.metadata as metadata

import pytest

from tendon_id import extras, zoo
from tendon_id.benchmarks.registry import BENCHMARKS
from tendon_id.cli import main

REQUIRES = [
    "numpy>=1.26",
    'corner>=2.2; extra == "posterior"',
    'tqdm>=4.66; extra == "progress"',
    'tqdm>=4.66; extra == "test"',
    "ruff>=0.6 ; extra == 'test'",
]


@pytest.fixture
def installed(monkeypatch):
    """A tendon-id distribution with the REQUIRES above, on a machine without corner and ruff."""
    requires, real = metadata.requires, metadata.distribution
    monkeypatch.setattr(metadata, "requires", lambda name: REQUIRES if name == "tendon-id" else requires(name))

    def distribution(name):
        if name in ("corner", "ruff"):
            raise metadata.PackageNotFoundError(name)
        return real(name)

    monkeypatch.setattr(metadata, "distribution", distribution)


def test_extra_requirements_are_read_from_the_package_metadata(installed):
    assert extras.extra_requirements("posterior") == ["corner"]
    assert extras.extra_requirements("test") == ["tqdm", "ruff"]
    assert extras.extra_requirements("nothing") == []
    extras.require_extra("progress", "a progress bar")  # installed: no error


def test_a_missing_extra_names_the_pip_command(installed):
    with pytest.raises(extras.MissingExtraError, match=r"pip install 'tendon-id\[posterior\]'"):
        extras.require_extra("posterior", "--posterior")


def test_calibrate_posterior_without_its_extra_exits_2_before_reading_any_data(installed, tmp_path, capsys):
    missing = tmp_path / "never-read.parquet"  # were it read first, the error would name this file
    code = main(["calibrate", "--data", str(missing), "--posterior", "--out", str(tmp_path / "cal")])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "corner" in err and "pip install 'tendon-id[posterior]'" in err and "never-read" not in err
    assert not (tmp_path / "cal").exists()


@pytest.mark.parametrize("command, names", [("fit", zoo.names()), ("benchmark", list(BENCHMARKS))])
def test_help_lists_every_registered_name(capsys, command, names):
    assert main([command, "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())  # the help is wrapped to the terminal
    for name in names:
        assert name in text, f"{command} --help does not mention {name}"
