"""ROS 2 bags (:mod:`tendon_id.data.rosbag`): written with rosbags' writer, read back to the same recording."""

import shutil

import numpy as np
import pytest
from bags import MAPPING, signals, write_bag

from tendon_id.cli import main
from tendon_id.data import Recording
from tendon_id.data.mapping import load_mapping, read_files
from tendon_id.errors import RecordingError

DELAY_NS = 1_000_000  # the unstamped streams' receive delay in write_bag


def expected(streams) -> Recording:
    """The recording the alignment rule gives, derived here sample by sample."""
    joint_t, angles = streams["/joint_states"]
    arrivals = {t: streams[t][0] + DELAY_NS for t in ("/cells/act", "/cells/tip")}
    start = max(joint_t[0], *(a[0] for a in arrivals.values()))
    end = min(joint_t[-1], *(a[-1] for a in arrivals.values()))
    keep = (joint_t >= start) & (joint_t <= end)
    instants = joint_t[keep]

    def held(topic):
        # The last sample that had arrived at or before each instant.
        rows = [max(k for k, a in enumerate(arrivals[topic]) if a <= t) for t in instants]
        return streams[topic][1][rows]

    act, tip = held("/cells/act"), held("/cells/tip")
    return Recording.from_arrays(
        trajectory="run",
        t=(instants - instants[0]) * 1e-9,
        angles=angles[keep].reshape(-1, 2, 2),
        actuator=act.reshape(-1, 2, 3),
        terminal=tip,
        meta={"n_modules": 2},
    )


@pytest.fixture(scope="module")
def streams():
    return signals(duration_s=2.0)


@pytest.fixture()
def mapping(tmp_path):
    (tmp_path / "bag.toml").write_text(MAPPING)
    return load_mapping(tmp_path / "bag.toml")


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_a_bag_reads_back_to_the_same_recording(tmp_path, streams, mapping, storage):
    bag = write_bag(tmp_path / "run", streams, storage=storage)
    (rec,) = read_files([bag], mapping)
    want = expected(streams)
    assert rec.n_frames == want.n_frames == 200  # 10 ms .. 2 s: the span every stream covers
    np.testing.assert_array_equal(rec.time, want.time)
    np.testing.assert_array_equal(rec.angles, want.angles)  # the clock's own stream: exactly its samples
    np.testing.assert_array_equal(rec.actuator, want.actuator)
    np.testing.assert_array_equal(rec.terminal, want.terminal)
    assert rec.meta["clock"] == "/joint_states"


def test_a_bare_mcap_file_reads_too(tmp_path, streams, mapping):
    bag = write_bag(tmp_path / "run", streams)
    bare = tmp_path / "run.mcap"
    shutil.copy(next(bag.glob("*.mcap")), bare)
    (rec,) = read_files([bare], mapping)
    (folder,) = read_files([bag], mapping)
    np.testing.assert_array_equal(rec.frame.drop(columns="trajectory"), folder.frame.drop(columns="trajectory"))


def test_angles_between_samples_are_interpolated(tmp_path, streams):
    # With the slow tip stream as the clock, the angles fall between their samples.
    text = MAPPING.replace('clock = "/joint_states"', 'clock = "/cells/tip"')
    (tmp_path / "m.toml").write_text(text)
    bag = write_bag(tmp_path / "run", streams)
    (rec,) = read_files([bag], load_mapping(tmp_path / "m.toml"))
    joint_t, angles = streams["/joint_states"]
    instants = streams["/cells/tip"][0] + DELAY_NS
    instants = instants[(instants >= DELAY_NS) & (instants <= joint_t[-1])]
    want = np.interp(instants, joint_t, angles[:, 0])
    np.testing.assert_allclose(rec.angles[:, 0, 0], want, rtol=0, atol=1e-15)


@pytest.mark.parametrize(
    "edit, match",
    [
        (("/cells/tip", "/cells/nope"), "no topic '/cells/nope'"),
        (("data[{i0}]", "force[{i0}]"), "no field 'force"),
        (("position[{2*k0}]", "position[{2*k0 + 9}]"), "out of range"),
        (("position[{2*k0}]", "name[{k0}]"), "not a number"),
    ],
)
def test_a_bad_topic_or_field_names_the_bag_topic_and_field(tmp_path, streams, edit, match):
    (tmp_path / "m.toml").write_text(MAPPING.replace(*edit))
    bag = write_bag(tmp_path / "run", streams)
    with pytest.raises(RecordingError, match=match) as err:
        read_files([bag], load_mapping(tmp_path / "m.toml"))
    assert "run" in str(err.value)


def test_convert_writes_the_native_format(tmp_path, streams, capsys):
    bag = write_bag(tmp_path / "run", streams)
    (tmp_path / "bag.toml").write_text(MAPPING)
    out = tmp_path / "run.parquet"
    code = main(["convert", "--mapping", str(tmp_path / "bag.toml"), "--data", str(bag), "--out", str(out)])
    assert code in (0, None)
    native = Recording.read(out)
    (direct,) = read_files([bag], load_mapping(tmp_path / "bag.toml"))
    np.testing.assert_array_equal(native.actuator, direct.actuator)
    np.testing.assert_array_equal(native.angles, direct.angles)
    assert native.trajectories == direct.trajectories
    # A bag without a mapping is a clear error (exit 2), not a traceback.
    assert main(["info", str(bag)]) == 2
    assert "--mapping" in capsys.readouterr().err
