"""Reading at scale (issue 42): the row-group reader and the trajectory codes give what they replace."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from test_data import make_recording

from tendon_id.data import Recording, rules
from tendon_id.data.io import read_columns, read_parquet
from tendon_id.data.passage import PassageRecording
from tendon_id.errors import RecordingError


def whole(path):
    """What read_parquet returned before: the whole table, then pandas."""
    return pq.read_table(path).to_pandas()


def same(path):
    got = read_columns(path, pq.read_schema(path))
    pd.testing.assert_frame_equal(got, whole(path), check_exact=True)
    return got


def test_own_files_read_the_same_in_row_groups(tmp_path):
    rec = make_recording(trajectories=("a", "b", "c"), frames=50)
    path = rec.write(tmp_path / "r.parquet")
    same(path)
    # Several row groups, a row group cut inside a trajectory, more columns than are read at once.
    table = pq.read_table(path)
    pq.write_table(table, tmp_path / "groups.parquet", row_group_size=17)
    assert pq.ParquetFile(tmp_path / "groups.parquet").num_row_groups > 1
    got = same(tmp_path / "groups.parquet")
    assert Recording(got, rec.meta).frame.equals(rec.frame)


def test_other_types_nulls_and_no_rows_read_as_to_pandas_reads_them(tmp_path):
    table = pa.table(
        {
            "trajectory": pa.array(["a", None, "b"]),
            "t": pa.array([0.0, None, 0.2]),  # a null float reads as NaN
            "count": pa.array([1, None, 3], pa.int64()),  # an int with a null reads as float
            "f32": pa.array([1.5, 2.5, 3.5], pa.float32()),
            "flag": pa.array([True, False, True]),
        }
    )
    pq.write_table(table, tmp_path / "mixed.parquet", row_group_size=2)
    same(tmp_path / "mixed.parquet")
    pq.write_table(table.slice(0, 0), tmp_path / "empty.parquet")
    assert len(same(tmp_path / "empty.parquet")) == 0


def test_a_file_pandas_wrote_keeps_its_index(tmp_path):
    df = pd.DataFrame({"trajectory": ["a", "a"], "t": [0.0, 0.1]}, index=[5, 7])
    df.to_parquet(tmp_path / "p.parquet")
    got = same(tmp_path / "p.parquet")
    assert list(got.index) == [5, 7]


def test_float_columns_are_not_copied_into_one_block(tmp_path):
    path = make_recording(frames=30).write(tmp_path / "r.parquet")
    frame, meta = read_parquet(path)
    assert meta["n_modules"] == 3
    # One array per float column, and the recording keeps them (no consolidation copy).
    rec = Recording(frame, meta)
    assert np.shares_memory(rec.frame["t"].to_numpy(), frame["t"].to_numpy())


def test_trajectory_codes_name_the_same_ids_and_rows():
    f = pd.DataFrame({"trajectory": pd.Series(["b", "b", "a", "a", "c"], dtype="str")})
    codes, names = rules.trajectory_codes(f)
    assert list(names[codes]) == ["b", "b", "a", "a", "c"]
    assert np.array_equal(rules.check_trajectory_ids(f), np.array(["b", "b", "a", "a", "c"]))
    for bad, text in ((None, "missing trajectory id"), ("", "empty trajectory id")):
        g = f.assign(trajectory=["b", "b", "a", bad, "c"])
        with pytest.raises(RecordingError, match=text) as exc:
            rules.trajectory_codes(g)
        assert exc.value.row == 3


def test_errors_name_the_trajectory_from_its_code():
    ids = np.array([0, 0, 1, 0])
    names = np.array(["run-a", "run-b"])
    with pytest.raises(RecordingError, match="'run-a' appears in two separate blocks") as exc:
        rules.check_contiguous_trajectories(ids, names=names)
    assert exc.value.row == 3
    with pytest.raises(RecordingError, match="within trajectory 'run-b'") as exc:
        rules.check_time_increases(np.array([0.0, 0.1, 0.5, 0.4]), np.array([0, 0, 1, 1]), names=names)
    assert exc.value.row == 3


def test_recordings_report_the_same_first_problem(tmp_path):
    rec = make_recording(trajectories=("a", "b"), frames=5)
    f = rec.frame.copy()
    f.loc[7, "t"] = 0.0
    with pytest.raises(RecordingError, match="within trajectory 'b'") as exc:
        Recording(f, rec.meta)
    assert exc.value.row == 7
    g = pd.concat([rec.frame, rec.frame.iloc[:2]], ignore_index=True)
    with pytest.raises(RecordingError, match="'a' appears in two separate blocks"):
        Recording(g, rec.meta)
    p = pd.DataFrame({"trajectory": ["x", "x", "y"], "t": [0.0, 0.1, 0.0], "input": 1.0, "output": 1.0})
    assert list(PassageRecording(p).trajectory_starts) == [True, False, True]


def test_a_recording_too_large_for_memory_is_a_recording_error(tmp_path, monkeypatch):
    import tendon_id.data.io as io

    path = make_recording(trajectories=("a",), frames=20).write(tmp_path / "r.parquet")

    def no_memory(path, schema):
        raise MemoryError

    monkeypatch.setattr(io, "read_columns", no_memory)
    with pytest.raises(RecordingError, match=r"r\.parquet.*20 rows of \d+ columns do not fit in memory"):
        read_parquet(path)
