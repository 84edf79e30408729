"""Tests of the Recording schema, its IO and its validation (docs/guide/data.rst)."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from tendon_id.data import SCHEMA_VERSION, Recording, column_names
from tendon_id.errors import ConfigError, RecordingError, TendonIdError

N = 3
FRAMES = 20


def make_recording(n=N, trajectories=("a", "b"), frames=FRAMES, truth=True, seed=0, meta=None, extra=None):
    """A small valid recording: tensions 80-150 N, angles within +-0.3 rad, 10 Hz."""
    rng = np.random.default_rng(seed)
    T = frames * len(trajectories)
    traj = np.repeat(np.asarray(trajectories, dtype=object), frames)
    t = np.tile(np.arange(frames) * 0.1, len(trajectories))
    angles = rng.uniform(-0.3, 0.3, size=(T, n, 2))
    actuator = rng.uniform(80.0, 150.0, size=(T, n, 3))
    jt = rng.uniform(80.0, 150.0, size=(T, n, 3))
    base = {
        "schema_version": 1,
        "n_modules": n,
        "sample_rate_hz": 10.0,
        "protocol": "planned-paths",
        "robot": {"disk_radius_m": 0.01, "alpha_0_rad": [0.1, 0.2]},
        "recipe": "unit-test",
        "effects": ["contact", "stick_slip"],
        "seed": seed,
    }
    base.update(meta or {})
    return Recording.from_arrays(
        trajectory=traj,
        t=t,
        angles=angles,
        actuator=actuator,
        terminal=jt[:, n - 1],
        joint_truth=jt if truth else None,
        meta=base,
        extra=extra,
    )


def assert_same_data(a: Recording, b: Recording):
    assert a.n_modules == b.n_modules
    assert a.trajectories == b.trajectories
    np.testing.assert_array_equal(a.time, b.time)
    np.testing.assert_array_equal(a.trajectory_ids, b.trajectory_ids)
    np.testing.assert_array_equal(a.angles, b.angles)
    np.testing.assert_array_equal(a.actuator, b.actuator)
    np.testing.assert_array_equal(a.terminal, b.terminal)
    if a.joint_truth is None:
        assert b.joint_truth is None
    else:
        np.testing.assert_array_equal(a.joint_truth, b.joint_truth)


# ------------------------------------------------------------------------------------------
# schema and accessors
# ------------------------------------------------------------------------------------------


def test_column_names_canonical_order():
    cols = column_names(2)
    assert cols[:6] == ["trajectory", "t", "theta_1_x", "theta_1_y", "theta_2_x", "theta_2_y"]
    assert cols[6:12] == [f"tension_act_{j}_{i}" for j in (1, 2) for i in (1, 2, 3)]
    assert cols[12:] == [f"tension_joint_{j}_{i}" for j in (1, 2) for i in (1, 2, 3)]
    no_truth = column_names(2, truth=False)
    assert no_truth[-3:] == ["tension_joint_2_1", "tension_joint_2_2", "tension_joint_2_3"]
    assert "tension_joint_1_1" not in no_truth
    assert len(column_names(12)) == 2 + 24 + 36 + 36
    assert SCHEMA_VERSION == 1


def test_accessors_shapes_and_values():
    rec = make_recording()
    T = 2 * FRAMES
    assert len(rec) == rec.n_frames == T
    assert rec.n_modules == N
    assert rec.trajectories == ["a", "b"]
    assert rec.angles.shape == (T, N, 2)
    assert rec.actuator.shape == (T, N, 3)
    assert rec.terminal.shape == (T, 3)
    assert rec.joint_truth.shape == (T, N, 3)
    assert rec.has_truth
    f = rec.frame
    np.testing.assert_array_equal(rec.angles[:, 1, 0], f["theta_2_x"].to_numpy())
    np.testing.assert_array_equal(rec.angles[:, 2, 1], f["theta_3_y"].to_numpy())
    np.testing.assert_array_equal(rec.actuator[:, 1, 2], f["tension_act_2_3"].to_numpy())
    np.testing.assert_array_equal(rec.joint_truth[:, 0, 1], f["tension_joint_1_2"].to_numpy())
    np.testing.assert_array_equal(rec.joint_truth[:, N - 1], rec.terminal)
    assert rec.sample_rate_hz == 10.0 and rec.dt == pytest.approx(0.1)
    assert rec.protocol == "planned-paths"
    starts = rec.trajectory_starts
    assert starts.dtype == bool and starts.sum() == 2 and starts[0] and starts[FRAMES]
    assert rec.trajectory_ids.dtype.kind == "U"
    assert list(f.columns) == column_names(N)
    assert "n_modules=3" in repr(rec)


def test_accessor_arrays_are_copies():
    rec = make_recording()
    a = rec.angles
    a[:] = 99.0
    t = rec.time
    t[:] = -1.0
    assert np.abs(rec.angles).max() <= 0.3
    assert rec.time[0] == 0.0


def test_meta_is_a_copy():
    rec = make_recording()
    m = rec.meta
    m["effects"].append("x")
    m["n_modules"] = 99
    assert rec.meta["effects"] == ["contact", "stick_slip"]
    assert rec.n_modules == N


def test_integer_trajectory_ids_become_str_and_nmodules_is_inferred():
    rec = make_recording()
    frame = rec.frame.copy()
    frame["trajectory"] = np.repeat([7, 8], FRAMES)
    r2 = Recording(frame)
    assert r2.trajectories == ["7", "8"]
    assert r2.n_modules == N
    assert r2.meta["schema_version"] == 1
    assert r2.meta["effects"] == [] and r2.meta["seed"] is None


def test_sample_rate_inferred_from_time_when_meta_lacks_it():
    rec = make_recording()
    frame = rec.frame.copy()
    frame["t"] = frame["t"] / 10.0  # 100 Hz
    assert Recording(frame).sample_rate_hz == pytest.approx(100.0)
    assert Recording(frame, {"sample_rate_hz": 50}).sample_rate_hz == 50.0


def test_no_truth_recording():
    rec = make_recording(truth=False)
    assert not rec.has_truth and rec.joint_truth is None
    assert rec.describe()["truth"] == {"terminal": True, "intermediate": False, "intermediate_joints": []}


def test_partial_truth_is_not_joint_truth():
    rec = make_recording()
    frame = rec.frame.drop(columns=["tension_joint_2_3"])
    r2 = Recording(frame, rec.meta)
    assert r2.joint_truth is None and not r2.has_truth
    assert r2.describe()["truth"]["intermediate_joints"] == [1]


def test_extra_columns_kept_and_ignored(tmp_path):
    T = 2 * FRAMES
    rec = make_recording(extra={"my_signal": np.arange(T, dtype=float), "note": np.array(["x"] * T)})
    assert "my_signal" in rec.frame.columns and "note" in rec.frame.columns
    assert rec.angles.shape == (T, N, 2)
    for name in ("x.parquet", "x.csv"):
        back = Recording.read(rec.write(tmp_path / name))
        np.testing.assert_array_equal(back.frame["my_signal"].to_numpy(), np.arange(T))
        assert list(back.frame["note"].astype(str)) == ["x"] * T
    # a NaN in an extra column is not an error
    frame = rec.frame.copy()
    frame["my_signal"] = np.nan
    Recording(frame, rec.meta)


# ------------------------------------------------------------------------------------------
# IO
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["rec.parquet", "rec.csv"])
def test_round_trip(tmp_path, name):
    rec = make_recording()
    out = rec.write(tmp_path / name)
    assert out == tmp_path / name and out.exists()
    back = Recording.read(out)
    assert_same_data(rec, back)
    assert back.meta == rec.meta
    assert back.source == str(out)
    if name.endswith(".csv"):
        side = tmp_path / "rec.json"
        assert json.loads(side.read_text())["n_modules"] == N
    # nothing but the outputs is left in the folder (temp files were renamed away)
    assert sorted(p.name for p in tmp_path.iterdir()) == (
        ["rec.csv", "rec.json"] if name.endswith(".csv") else ["rec.parquet"]
    )


def test_parquet_meta_in_schema_metadata(tmp_path):
    import pyarrow.parquet as pq

    rec = make_recording()
    path = rec.write(tmp_path / "r.parquet")
    md = pq.read_schema(path).metadata
    assert json.loads(md[b"tendon_id"]) == rec.meta


def test_parquet_byte_identical(tmp_path):
    a = make_recording(seed=3).write(tmp_path / "a.parquet")
    b = make_recording(seed=3).write(tmp_path / "b.parquet")
    assert a.read_bytes() == b.read_bytes()
    # and rewriting what was read back gives the same bytes again
    c = Recording.read(a).write(tmp_path / "c.parquet")
    assert c.read_bytes() == a.read_bytes()
    # different data gives different bytes
    d = make_recording(seed=4).write(tmp_path / "d.parquet")
    assert d.read_bytes() != a.read_bytes()


def test_write_overwrites_atomically(tmp_path):
    path = tmp_path / "sub" / "r.parquet"
    make_recording(seed=1).write(path)
    rec = make_recording(seed=2)
    rec.write(path)
    assert_same_data(Recording.read(path), rec)
    assert [p.name for p in path.parent.iterdir()] == ["r.parquet"]


def test_csv_from_a_separate_program_loads(tmp_path):
    """A CSV written with the csv module following docs/guide/data.rst, no sidecar."""
    path = tmp_path / "bench.csv"
    rng = np.random.default_rng(5)
    header = (
        ["trajectory", "t"]
        + [f"theta_{k}_{a}" for k in (1, 2) for a in "xy"]
        + [f"tension_act_{j}_{i}" for j in (1, 2) for i in (1, 2, 3)]
        + [f"tension_joint_2_{i}" for i in (1, 2, 3)]
        + ["operator_note"]
    )
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for traj in (1, 2):
            for n in range(15):
                row = [traj, f"{n * 0.1:.1f}"]
                row += [f"{x:.5f}" for x in rng.uniform(-0.3, 0.3, 4)]
                row += [f"{x:.3f}" for x in rng.uniform(80, 150, 9)]
                row += ["ok"]
                w.writerow(row)
    rec = Recording.read(path)
    assert rec.n_modules == 2
    assert rec.trajectories == ["1", "2"]
    assert rec.n_frames == 30
    assert not rec.has_truth and rec.joint_truth is None
    assert rec.sample_rate_hz == pytest.approx(10.0)
    assert rec.meta["schema_version"] == 1 and rec.meta["protocol"] is None
    assert rec.frame["operator_note"].iloc[0] == "ok"
    assert rec.terminal.shape == (30, 3)
    rec.check_history_window(15)


def test_parquet_from_plain_pandas_loads(tmp_path):
    """A Parquet file written by pandas (its own metadata, an index, int ids) loads."""
    rec = make_recording(truth=False)
    frame = rec.frame.copy()
    frame["trajectory"] = np.repeat([1, 2], FRAMES)
    frame.index = frame.index + 100
    path = tmp_path / "plain.parquet"
    frame.to_parquet(path)
    back = Recording.read(path)
    assert back.trajectories == ["1", "2"]
    assert back.n_modules == N and back.meta["protocol"] is None
    np.testing.assert_array_equal(back.angles, rec.angles)


def test_with_meta():
    rec = make_recording()
    r2 = rec.with_meta(protocol="posterior-6", seed=9)
    assert r2.protocol == "posterior-6" and r2.meta["seed"] == 9
    assert rec.protocol == "planned-paths"
    assert_same_data(rec, r2)


def test_read_errors_name_the_file(tmp_path):
    missing = tmp_path / "nope.parquet"
    with pytest.raises(RecordingError, match="nope.parquet"):
        Recording.read(missing)
    bad_suffix = tmp_path / "x.txt"
    bad_suffix.write_text("hello")
    with pytest.raises(RecordingError, match=r"x\.txt.*unknown file type"):
        Recording.read(bad_suffix)
    garbage = tmp_path / "garbage.parquet"
    garbage.write_bytes(b"this is not parquet")
    with pytest.raises(RecordingError, match="garbage.parquet"):
        Recording.read(garbage)
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    with pytest.raises(RecordingError, match="empty.csv"):
        Recording.read(empty)
    # a broken sidecar is named
    make_recording().write(tmp_path / "s.csv")
    (tmp_path / "s.json").write_text("{not json")
    with pytest.raises(RecordingError, match=r"s\.json"):
        Recording.read(tmp_path / "s.csv")
    with pytest.raises(RecordingError, match="unknown file type"):
        make_recording().write(tmp_path / "out.xlsx")
    # RecordingError is a user error (CLI exit code 2)
    assert issubclass(RecordingError, TendonIdError)


def test_newer_schema_version_is_rejected(tmp_path):
    rec = make_recording()
    rec.write(tmp_path / "r.csv")
    meta = json.loads((tmp_path / "r.json").read_text())
    meta["schema_version"] = SCHEMA_VERSION + 1
    (tmp_path / "r.json").write_text(json.dumps(meta))
    with pytest.raises(RecordingError, match=r"r\.csv.*schema_version"):
        Recording.read(tmp_path / "r.csv")


def test_bad_meta_types_rejected():
    rec = make_recording()
    with pytest.raises(RecordingError, match="sample_rate_hz"):
        Recording(rec.frame, {"sample_rate_hz": -1})
    with pytest.raises(RecordingError, match="n_modules"):
        Recording(rec.frame, {"n_modules": "three"})
    with pytest.raises(RecordingError, match="effects"):
        Recording(rec.frame, {"effects": [1, 2]})


# ------------------------------------------------------------------------------------------
# validation
# ------------------------------------------------------------------------------------------


def _set(frame, column, row, value):
    frame = frame.copy()
    if not isinstance(value, float):
        frame[column] = frame[column].astype(object)
    frame.loc[row, column] = value
    return frame


def _bad_frames():
    """(id, frame-editing function, column, row or None, extra text the message must contain)."""

    def drop(col):
        return lambda f: f.drop(columns=[col])

    def swap_blocks(f):
        # a a ... b b ... a a: trajectory 'a' in two separate blocks
        return pd.concat([f.iloc[:10], f.iloc[FRAMES:], f.iloc[10:FRAMES]], ignore_index=True)

    def stale_time(f):
        f = f.copy()
        f.loc[12, "t"] = f.loc[11, "t"]
        return f

    def extra_module(f):
        f = f.copy()
        f["theta_4_x"] = 0.1
        return f

    return [
        ("missing", drop("tension_act_2_2"), "tension_act_2_2", None, "missing required column"),
        ("missing-terminal", drop("tension_joint_3_1"), "tension_joint_3_1", None, "missing"),
        ("missing-t", drop("t"), "t", None, "missing"),
        ("nan", lambda f: _set(f, "theta_2_y", 7, np.nan), "theta_2_y", 7, "NaN"),
        ("inf", lambda f: _set(f, "tension_act_1_1", 3, np.inf), "tension_act_1_1", 3, "infinite"),
        ("negative", lambda f: _set(f, "tension_joint_3_2", 25, -1.0), "tension_joint_3_2", 25, "non-positive"),
        ("zero-truth", lambda f: _set(f, "tension_joint_1_1", 5, 0.0), "tension_joint_1_1", 5, "non-positive"),
        ("time", stale_time, "t", 12, "does not increase"),
        (
            "degrees",
            lambda f: _set(f, "theta_1_x", 4, 17.0),
            "theta_1_x",
            4,
            "looks like degrees; angles must be in rad",
        ),
        ("non-numeric", lambda f: _set(f, "theta_2_x", 9, "abc"), "theta_2_x", 9, "non-numeric"),
        ("blocks", swap_blocks, "trajectory", 30, "contiguous"),
        (
            "extra-module",
            extra_module,
            "theta_4_x",
            None,
            "n_modules is 3 in the metadata but the columns describe 4 modules",
        ),
    ]


BAD = _bad_frames()


@pytest.mark.parametrize("case", BAD, ids=[b[0] for b in BAD])
def test_bad_input_in_memory(case):
    _, edit, column, row, text = case
    rec = make_recording()
    with pytest.raises(RecordingError) as exc:
        Recording(edit(rec.frame), rec.meta)
    err = exc.value
    msg = str(err)
    assert err.column == column
    assert f"'{column}'" in msg
    assert text in msg
    assert err.row == row
    if row is not None:
        assert f"row {row}" in msg
    assert "\n" not in msg


@pytest.mark.parametrize("case", BAD, ids=[b[0] for b in BAD])
def test_bad_input_from_csv_names_file_column_row(tmp_path, case):
    _, edit, column, row, text = case
    rec = make_recording()
    rec.write(tmp_path / "bad_input.csv")  # valid file + sidecar
    edit(rec.frame).to_csv(tmp_path / "bad_input.csv", index=False)  # then corrupt the data
    with pytest.raises(RecordingError) as exc:
        Recording.read(tmp_path / "bad_input.csv")
    msg = str(exc.value)
    assert "bad_input.csv" in msg
    assert f"'{column}'" in msg and text in msg
    if row is not None:
        assert f"row {row}" in msg


def test_bad_input_from_parquet_names_file(tmp_path):
    rec = make_recording()
    bad = Recording(_set(rec.frame, "theta_3_y", 33, 45.0), rec.meta, validate=False)
    path = bad.write(tmp_path / "degrees.parquet")
    with pytest.raises(RecordingError, match=r"degrees\.parquet, column 'theta_3_y', row 33: .*degrees"):
        Recording.read(path)
    # validate=False still reads it, for inspection
    assert Recording.read(path, validate=False).n_frames == rec.n_frames


def test_first_offending_row_across_columns():
    rec = make_recording()
    f = _set(rec.frame, "tension_act_3_3", 2, np.nan)
    f = _set(f, "theta_1_x", 6, np.nan)
    with pytest.raises(RecordingError) as exc:
        Recording(f, rec.meta)
    assert (exc.value.column, exc.value.row) == ("tension_act_3_3", 2)


def test_meta_n_modules_larger_than_columns():
    rec = make_recording()
    with pytest.raises(
        RecordingError, match="n_modules is 4 in the metadata but the columns describe 3 modules"
    ) as exc:
        Recording(rec.frame, {**rec.meta, "n_modules": 4})
    assert exc.value.column == "theta_4_x"


def test_inconsistent_numbering():
    rec = make_recording()
    # a gap in the numbering: module 3 is complete but a column of module 2 is missing
    f = rec.frame.drop(columns=["theta_2_y"])
    with pytest.raises(RecordingError, match="theta_2_y"):
        Recording(f)
    # zero-based numbering is refused rather than silently dropping a module
    f = rec.frame.rename(columns={"theta_1_x": "theta_0_x"})
    with pytest.raises(RecordingError, match="theta_0_x.*numbered from 1"):
        Recording(f)


def test_empty_recording(tmp_path):
    rec = make_recording()
    with pytest.raises(RecordingError, match="empty"):
        Recording(rec.frame.iloc[:0], rec.meta)
    path = tmp_path / "header_only.csv"
    rec.frame.iloc[:0].to_csv(path, index=False)
    with pytest.raises(RecordingError, match=r"header_only\.csv.*empty"):
        Recording.read(path)


def test_missing_trajectory_id():
    rec = make_recording()
    f = _set(rec.frame, "trajectory", 11, None)
    with pytest.raises(RecordingError) as exc:
        Recording(f, rec.meta)
    assert (exc.value.column, exc.value.row) == ("trajectory", 11)


def test_validation_scales_to_a_large_recording():
    # 100 000 frames x 98 columns must validate quickly (vectorised); no timing assertion here
    rng = np.random.default_rng(0)
    T, n = 100_000, 12
    rec = Recording.from_arrays(
        trajectory=np.repeat([f"tr{i}" for i in range(100)], T // 100),
        t=np.tile(np.arange(T // 100) * 0.1, 100),
        angles=rng.uniform(-0.3, 0.3, (T, n, 2)),
        actuator=rng.uniform(80, 150, (T, n, 3)),
        terminal=rng.uniform(80, 150, (T, 3)),
    )
    assert rec.n_frames == T and len(rec.trajectories) == 100


# ------------------------------------------------------------------------------------------
# selection
# ------------------------------------------------------------------------------------------


def test_fitting_view_hides_intermediate_truth():
    rec = make_recording(extra={"my_signal": np.zeros(2 * FRAMES)})
    view = rec.fitting_view()
    assert rec.has_truth
    assert not view.has_truth and view.joint_truth is None
    assert not [
        c for c in view.frame.columns if c.startswith("tension_joint_") and not c.startswith(f"tension_joint_{N}_")
    ]
    np.testing.assert_array_equal(view.terminal, rec.terminal)
    np.testing.assert_array_equal(view.actuator, rec.actuator)
    assert "my_signal" in view.frame.columns
    with pytest.raises(KeyError):
        view.frame["tension_joint_1_1"]
    assert view.meta == rec.meta
    # the original is untouched
    assert rec.joint_truth is not None


def test_select():
    rec = make_recording(trajectories=("a", "b", "c"))
    sub = rec.select(["c", "a"])
    assert sub.trajectories == ["a", "c"]  # recording order
    assert sub.n_frames == 2 * FRAMES
    np.testing.assert_array_equal(sub.angles, rec.angles[np.r_[0:FRAMES, 2 * FRAMES : 3 * FRAMES]])
    with pytest.raises(RecordingError, match="'z'"):
        rec.select(["z"])
    with pytest.raises(RecordingError):
        rec.select([])


def test_split_by_trajectory_deterministic_and_disjoint():
    ids = tuple(f"tr{i}" for i in range(10))
    rec = make_recording(trajectories=ids, frames=5)
    train, test = rec.split((0.7, 0.3), seed=1)
    assert len(train.trajectories) == 7 and len(test.trajectories) == 3
    assert not set(train.trajectories) & set(test.trajectories)
    assert set(train.trajectories) | set(test.trajectories) == set(ids)
    assert train.n_frames + test.n_frames == rec.n_frames
    again = rec.split((0.7, 0.3), seed=1)
    assert [p.trajectories for p in again] == [train.trajectories, test.trajectories]
    others = {tuple(rec.split((0.7, 0.3), seed=s)[1].trajectories) for s in range(10)}
    assert len(others) > 1  # the seed matters
    # every trajectory stays whole
    for part in (train, test):
        for tid in part.trajectories:
            assert (part.trajectory_ids == tid).sum() == 5


def test_split_three_parts_each_nonempty():
    rec = make_recording(trajectories=("a", "b", "c"))
    parts = rec.split((0.8, 0.1, 0.1), seed=0)
    assert [len(p.trajectories) for p in parts] == [1, 1, 1]
    with pytest.raises(RecordingError, match="trajectories"):
        make_recording(trajectories=("a", "b")).split((0.5, 0.3, 0.2))
    with pytest.raises(ConfigError):
        rec.split((0.5, 0.6))


def test_concat():
    a = make_recording(trajectories=("a", "b"), seed=1)
    b = make_recording(
        trajectories=("c",), seed=2, meta={"protocol": "posterior-3", "effects": ["contact", "viscoelastic"]}
    )
    both = Recording.concat([a, b])
    assert both.trajectories == ["a", "b", "c"]
    np.testing.assert_array_equal(both.angles, np.concatenate([a.angles, b.angles]))
    assert both.protocol is None  # differs between parts
    assert both.meta["effects"] == ["contact", "stick_slip", "viscoelastic"]
    assert both.has_truth
    # truth kept only where every part has it
    assert not Recording.concat([a, make_recording(trajectories=("d",), truth=False)]).has_truth
    with pytest.raises(RecordingError, match="'a'"):
        Recording.concat([a, make_recording(trajectories=("a",))])
    with pytest.raises(RecordingError, match="modules"):
        Recording.concat([a, make_recording(n=2, trajectories=("z",))])


def test_check_history_window():
    rec = make_recording(trajectories=("long", "short"), frames=FRAMES)
    short = rec.select(["long"])
    f = pd.concat([short.frame, rec.frame.iloc[FRAMES : FRAMES + 5]], ignore_index=True)
    r2 = Recording(f, rec.meta)
    r2.check_history_window(5)
    with pytest.raises(RecordingError, match="'short'.*5 frames.*window of 6") as exc:
        r2.check_history_window(6)
    assert exc.value.column == "trajectory" and exc.value.row == FRAMES


def test_summary():
    rec = make_recording()
    s = rec.describe()
    json.dumps(s)  # serialisable for `tendon-id info --json`
    assert s["n_modules"] == N and s["n_frames"] == 2 * FRAMES and s["n_trajectories"] == 2
    assert s["trajectories"] == {"a": FRAMES, "b": FRAMES}
    assert s["duration_s"] == pytest.approx(2 * FRAMES * 0.1)
    assert s["truth"] == {"terminal": True, "intermediate": True, "intermediate_joints": [1, 2]}
    r = s["ranges"]
    assert -0.3 <= r["angle_rad"]["min"] < r["angle_rad"]["max"] <= 0.3
    assert r["angle_deg"]["max"] == pytest.approx(np.degrees(r["angle_rad"]["max"]))
    assert 80 <= r["actuator_n"]["min"] and r["terminal_n"]["max"] <= 150
    assert s["effects"] == ["contact", "stick_slip"] and s["recipe"] == "unit-test"
    assert s["seed"] == 0 and s["protocol"] == "planned-paths" and s["sample_rate_hz"] == 10.0


def test_importable_without_torch():
    code = (
        "import sys; sys.modules['torch'] = None; import tendon_id.data as d; "
        "assert 'torch' not in [m for m in sys.modules if sys.modules[m] is not None]"
    )
    env = dict(os.environ)
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
    subprocess.run([sys.executable, "-c", code], check=True, env=env)
