"""A recording that does not describe its robot is never defaulted silently (issue 41)."""

import warnings

import pytest

from tendon_id.cli import main
from tendon_id.datasets import load
from tendon_id.errors import DefaultedGeometryWarning
from tendon_id.geometry import RobotGeometry
from tendon_id.zoo.inputs import robot_of


@pytest.fixture(scope="module")
def described():
    return load("snake12-paper", protocol="posterior-6", frames=200, seed=2, progress=False)


def _warnings(recs, robot=None):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        geometry = robot_of(recs, robot)
    return geometry, [str(w.message) for w in caught if issubclass(w.category, DefaultedGeometryWarning)]


def test_a_described_robot_or_an_explicit_one_warns_nothing(described):
    assert _warnings([described])[1] == []
    assert _warnings([described.with_meta(robot=None)], RobotGeometry(n_modules=12))[1] == []


def test_a_recording_without_a_robot_warns_naming_every_defaulted_value(described):
    geometry, messages = _warnings([described.with_meta(robot=None)])
    (message,) = messages
    assert "describe no robot" in message
    for key, value in RobotGeometry(n_modules=12).to_dict().items():
        if key != "n_modules":
            assert f"{key}={value:.6g}" in message
    assert geometry == RobotGeometry(n_modules=12)


def test_a_partly_described_robot_names_only_what_was_defaulted(described):
    partial = described.with_meta(robot={"hole_radius": 0.02, "alpha_0": 0.1})
    geometry, (message,) = _warnings([partial])
    assert geometry.hole_radius == 0.02 and "undescribed" in message
    assert "hole_radius" not in message and "alpha_0=" not in message and "alpha_c=0.08" in message


def test_the_command_line_prints_the_warning_as_one_line(described, tmp_path, capsys):
    path = described.with_meta(robot=None).write(tmp_path / "bare.parquet")
    code = main(["fit", "capstan-simple", "--data", str(path), "--out", str(tmp_path / "m")])
    err = capsys.readouterr().err
    assert code == 0
    lines = [line for line in err.splitlines() if line.startswith("tendon-id: warning:")]
    assert len(lines) == 1 and "bare.parquet" in lines[0] and "hole_radius=0.012" in lines[0]
