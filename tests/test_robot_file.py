"""Robot files (:mod:`tendon_id.robot_file`): the paper's robot as one, units, azimuths and tendon counts."""

import math

import numpy as np
import pandas as pd
import pytest

from tendon_id.data import Recording
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError, RecordingError
from tendon_id.geometry import RobotGeometry, tendon_azimuths
from tendon_id.robot_file import load_robot, resolve_robot, robot_names
from tendon_id.sim import Recipe


def test_the_paper_robot_file_is_the_paper_robot():
    robot = load_robot("snake12-paper")
    # The values the recipes held inline before robot files existed (and RobotGeometry's defaults).
    inline = dict(n_modules=12, link_length=0.060, joint_gap=0.010, hole_radius=0.012, alpha_0=0.05, alpha_c=0.08)
    assert robot == RobotGeometry(**inline, azimuth_step=2.0 * np.pi / 36.0)
    assert robot.to_dict() == RobotGeometry().to_dict()
    assert "n_tendons" not in robot.to_dict()  # a 3-tendon robot's metadata is what it was


def test_the_bundled_recipes_read_the_robot_file():
    assert load_recipe("snake12-paper").robot == load_robot("snake12-paper")
    elastic = load_recipe("snake12-elastic").robot
    assert elastic.alpha_c == 0.03 and elastic.hole_radius == 0.012  # a key beside file= overrides the file's


def test_azimuths_follow_the_papers_pattern_for_any_count():
    # psi[j, i] = 2 pi i / n + j delta, written out here for n = 3, 4 and 2.
    for n in (3, 4, 2):
        g = RobotGeometry(n_modules=5, n_tendons=n, azimuth_step=0.1)
        expected = [[2 * math.pi * i / n + j * 0.1 for i in range(n)] for j in range(5)]
        np.testing.assert_allclose(tendon_azimuths(g), expected, rtol=0, atol=1e-15)
    quad = load_robot("snake6-quad")
    np.testing.assert_allclose(np.degrees(tendon_azimuths(quad)[1]), [15, 105, 195, 285], atol=1e-12)
    planar = load_robot("planar6-pair")
    assert planar.bending_axes == 1
    np.testing.assert_allclose(np.degrees(tendon_azimuths(planar)), [[0, 180]] * 6, atol=1e-12)


def test_lengths_and_angles_take_units():
    g = RobotGeometry.from_dict(
        {"n_modules": 4, "hole_radius": "20 mm", "azimuth_step": "10 deg", "alpha_c": "50 mrad"}
    )
    assert g.hole_radius == pytest.approx(0.020, abs=1e-15)
    assert g.azimuth_step == pytest.approx(math.radians(10), abs=1e-15)
    assert g.alpha_c == pytest.approx(0.050, abs=1e-15)


@pytest.mark.parametrize(
    "robot, match",
    [
        ({"hole_radius": "20 N"}, "hole_radius"),
        ({"hole_radius": "0.02"}, "hole_radius"),  # a length needs its unit
        ({"azimuth_step": "3 mm"}, "azimuth_step"),
        ({"n_tendons": 1}, "n_tendons"),
        ({"bending_axes": 3}, "bending_axes"),
        ({"n_tendons": 4, "azimuths": [0.0, 1.0, 2.0]}, "azimuths"),
        ({"n_tendons": 2, "azimuths": [0.0, 2 * math.pi]}, "share an azimuth"),
        ({"n_modules": 3, "n_tendons": 2, "azimuths": [[0, 1], [0, 1]]}, "azimuths"),
    ],
)
def test_bad_robots_name_the_setting(robot, match):
    with pytest.raises(ConfigError, match=match):
        RobotGeometry.from_dict({"n_modules": 4, **robot})


def test_every_set_its_own_holes(tmp_path):
    f = tmp_path / "mine.toml"
    f.write_text(
        'n_modules = 2\nn_tendons = 2\nbending_axes = 1\nlink_length = "40 mm"\njoint_gap = "8 mm"\n'
        'hole_radius = "10 mm"\n[azimuths]\nsets = [["0 deg", "180 deg"], ["5 deg", "185 deg"]]\n'
    )
    g = load_robot(f)
    np.testing.assert_allclose(np.degrees(tendon_azimuths(g)), [[0, 180], [5, 185]], atol=1e-12)
    # A relative path is read from the describing file's folder, and keys beside it override.
    assert resolve_robot({"file": "mine.toml", "hole_radius": 0.005}, base=tmp_path)["hole_radius"] == 0.005


def test_a_robot_file_names_its_mistakes(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text('n_modules = 4\nhole_radius = "12 mm"\nholes = 3\n')
    with pytest.raises(ConfigError, match=r"bad\.toml.*holes"):
        load_robot(f)
    with pytest.raises(ConfigError, match="bundled robots: .*snake12-paper"):
        load_robot("no-such-robot")
    assert {"snake12-paper", "snake6-quad", "planar6-pair"} <= set(robot_names())


def test_a_recipe_needs_one_friction_law_per_tendon():
    d = {"name": "x", "robot": {"file": "snake6-quad"}, "friction": {"A": [0.3, 0.3, 0.3], "B": [0.1, 0.1, 0.1]}}
    with pytest.raises(ConfigError, match="4 per set"):
        Recipe.from_dict(d)


def _frame(n_tendons: int) -> pd.DataFrame:
    cols = {"trajectory": ["a"] * 3, "t": [0.0, 0.1, 0.2]}
    for k in (1, 2):
        cols[f"theta_{k}_x"] = [0.0] * 3
        cols[f"theta_{k}_y"] = [0.0] * 3
    for j in (1, 2):
        for i in range(1, n_tendons + 1):
            cols[f"tension_act_{j}_{i}"] = [50.0] * 3
    for i in range(1, n_tendons + 1):
        cols[f"tension_joint_2_{i}"] = [40.0] * 3
    return pd.DataFrame(cols)


def test_a_recording_takes_its_tendon_count_from_its_robot_or_columns():
    rec = Recording(_frame(4))
    assert rec.n_tendons == 4 and rec.actuator.shape == (3, 2, 4)
    with pytest.raises(RecordingError, match=r"tension_act_1_4.*tendons are numbered 1\.\.3"):
        Recording(_frame(4), {"robot": {"n_tendons": 3}})
    with pytest.raises(RecordingError, match="tension_act_1_3"):
        Recording(_frame(2), {"robot": {"n_tendons": 3}})  # the robot says 3: the third is missing


def test_a_mapping_names_its_robot_file(tmp_path):
    from tendon_id.data.mapping import load_mapping, read_files

    (tmp_path / "hinge2.toml").write_text(
        'n_modules = 2\nn_tendons = 2\nbending_axes = 1\nlink_length = "40 mm"\njoint_gap = "8 mm"\n'
        'hole_radius = "10 mm"\n[azimuths]\nfirst = ["0 deg", "180 deg"]\nstep = "0 deg"\n'
    )
    names = ["theta_1_x", "theta_2_x"]  # a hinge's log has no theta_y
    names += [f"tension_act_{j}_{i}" for j in (1, 2) for i in (1, 2)] + ["tension_joint_2_1", "tension_joint_2_2"]
    columns = "\n".join(
        f'{n} = {{ column = "{n}", unit = "{"deg" if n[0] == "t" and "theta" in n else "N"}" }}' for n in names
    )
    (tmp_path / "map.toml").write_text(
        f'kind = "snake"\n[columns]\nt = {{ column = "t", unit = "s" }}\n{columns}\n'
        '[meta]\nrobot = { file = "hinge2.toml", hole_radius = "11 mm" }\n'
    )
    frame = pd.DataFrame({"t": [0.0, 0.1, 0.2], **{n: [1.0] * 3 if "theta" in n else [50.0] * 3 for n in names}})
    frame.to_csv(tmp_path / "run.csv", index=False)
    (rec,) = read_files([tmp_path / "run.csv"], load_mapping(tmp_path / "map.toml"))
    robot = rec.meta["robot"]
    assert rec.n_tendons == 2 and robot["bending_axes"] == 1
    assert robot["hole_radius"] == pytest.approx(0.011, abs=1e-15)  # the mapping's key, with its unit, wins
    np.testing.assert_allclose(rec.angles[0, 0], [np.radians(1.0), 0.0])
    bent = pd.DataFrame({**rec.frame, "theta_2_y": [0.0, 0.01, 0.0]})
    with pytest.raises(RecordingError, match=r"theta_2_y.*row 1.*bends about one axis"):
        Recording(bent, rec.meta)
