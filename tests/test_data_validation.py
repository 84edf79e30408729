"""One test per rule of tendon_id.data.validation (docs/guide/data.rst), calling the free functions."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tendon_id.data import column_names
from tendon_id.data import rules as r
from tendon_id.data import validation as v
from tendon_id.errors import ConfigError, RecordingError

N = 2


def frame(frames=4, trajectories=("a", "b")):
    """A small valid normalised frame: tensions 100 N, angles 0.1 rad, 10 Hz."""
    T = frames * len(trajectories)
    data = {c: np.full(T, 100.0) for c in column_names(N)}
    data["trajectory"] = np.repeat(np.asarray(trajectories, dtype=object), frames)
    data["t"] = np.tile(np.arange(frames) * 0.1, len(trajectories))
    for c in column_names(N):
        if c.startswith("theta_"):
            data[c] = np.full(T, 0.1)
    return pd.DataFrame(data)[column_names(N)]


def raises(func, *args, column=None, row=None, text="", **kw):
    with pytest.raises(RecordingError) as exc:
        func(*args, source="f.csv", **kw)
    err = exc.value
    assert (err.column, err.row) == (column, row)
    assert err.file == "f.csv" and text in str(err) and str(err).startswith("f.csv")
    return err


def test_valid_frame_passes_every_rule():
    v.validate(frame(), N, source="f.csv")
    v.validate(frame())  # n_modules from the columns


def test_check_not_empty():
    raises(r.check_not_empty, frame().iloc[:0], text="empty")


def test_check_numbering():
    raises(v.check_numbering, ["t", "theta_0_x"], column="theta_0_x", text="numbered from 1")
    raises(v.check_numbering, ["tension_act_1_4"], column="tension_act_1_4", text="numbered 1..3")
    v.check_numbering(["theta_01_x", "user_signal"])  # not schema columns: kept and ignored


def test_check_n_modules():
    cols = list(frame().columns)
    assert v.check_n_modules(cols, None) == N
    raises(v.check_n_modules, cols, 3, column="theta_3_x", text="n_modules is 3 in the metadata")
    raises(v.check_n_modules, cols, 1, column="theta_2_x", text="describe 2 modules")
    raises(v.check_n_modules, ["trajectory", "t"], None, column="theta_1_x", text="cannot be inferred")


def test_check_required_columns():
    cols = [c for c in frame().columns if c != "tension_act_2_3"]
    raises(v.check_required_columns, cols, N, column="tension_act_2_3", text="(n_modules is 2)")
    err = raises(v.check_required_columns, cols[1:], N, column="trajectory")
    assert str(err).endswith("missing required column")


def test_check_numeric():
    f = frame()
    f["theta_1_y"] = f["theta_1_y"].astype(object)
    f.loc[5, "theta_1_y"] = "abc"
    raises(r.check_numeric, f, ["t", "theta_1_y"], column="theta_1_y", row=5, text="non-numeric value 'abc'")


def test_check_trajectory_ids():
    ids = r.check_trajectory_ids(frame())
    assert ids.dtype.kind == "U" and list(ids[:1]) == ["a"]
    f = frame()
    f.loc[3, "trajectory"] = None
    raises(r.check_trajectory_ids, f, column="trajectory", row=3, text="missing trajectory id")
    f.loc[3, "trajectory"] = ""
    raises(r.check_trajectory_ids, f, column="trajectory", row=3, text="empty trajectory id")


def test_check_contiguous_trajectories():
    r.check_contiguous_trajectories(np.array(["a", "a", "b"]))
    raises(
        r.check_contiguous_trajectories,
        np.array(["a", "b", "b", "a"]),
        column="trajectory",
        row=3,
        text="two separate blocks",
    )


def test_check_finite():
    a = {"t": np.arange(4.0), "x": np.array([1.0, 2.0, np.inf, 1.0]), "y": np.array([1.0, np.nan, 1.0, 1.0])}
    raises(r.check_finite, a, column="y", row=1, text="NaN value")
    raises(r.check_finite, {"x": a["x"]}, column="x", row=2, text="infinite value (inf)")


def test_check_positive_tensions():
    a = {"tension_act_1_1": np.array([1.0, 0.0]), "tension_act_1_2": np.array([-2.0, 1.0])}
    raises(r.check_positive_tensions, a, column="tension_act_1_2", row=0, text="non-positive tension -2 N")


def test_check_angles_in_rad():
    v.check_angles_in_rad({"theta_1_x": np.array([-np.pi, np.pi])})
    raises(
        v.check_angles_in_rad,
        {"theta_1_x": np.array([0.1, 45.0])},
        column="theta_1_x",
        row=1,
        text="looks like degrees",
    )


def test_check_time_increases():
    ids = np.array(["a", "a", "b", "b"])
    r.check_time_increases(np.array([0.0, 0.1, 0.0, 0.1]), ids)  # time restarts per trajectory
    raises(
        r.check_time_increases,
        np.array([0.0, 0.1, 0.0, 0.0]),
        ids,
        column="t",
        row=3,
        text="time does not increase within trajectory 'b' (t = 0 s after 0 s)",
    )


def test_check_history_window():
    f = frame(frames=4, trajectories=("a", "b"))
    v.check_history_window(f, 4)
    raises(v.check_history_window, f, 5, column="trajectory", row=0, text="fewer than the history window")
    with pytest.raises(ConfigError, match="positive integer"):
        v.check_history_window(f, 0)


def test_validate_runs_rules_in_order():
    # A frame that breaks two rules reports the earlier one: non-numeric data before NaN.
    f = frame()
    f.loc[1, "tension_act_1_1"] = np.nan
    f["theta_2_x"] = "x"
    raises(v.validate, f, N, column="theta_2_x", row=0, text="non-numeric")
