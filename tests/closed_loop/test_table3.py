"""Table III's benchmark: its JSON floor, nulls for runs that never settle, and its page."""

import json

import numpy as np
import pytest

from tendon_id.benchmarks.table3 import PAPER_TABLE3, _aggregate, closed_loop_tests, format_table3
from tendon_id.cli import main
from tendon_id.datasets import load
from tendon_id.report.closed_loop import write_table3_page
from tendon_id.zoo import make


def _run(seed, settle, estimator="capstan-nonsmooth"):
    why = {
        "estimate_rmse_n": 1.0,
        "estimate_bias_n": 0.0,
        "torque_error_nm": 0.1,
        "stick_fraction": 0.1,
        "reverse_fraction": 0.0,
        "stick_fraction_hold": 0.1,
        "intermediate_rmse_n": 2.0,
        "load_error_nm": 0.05,
    }
    return {
        "regime": "posterior-3",
        "estimator": estimator,
        "loop": 1,
        "seed": seed,
        "rise_s": 1.0,
        "settle_s": settle,
        "rms_deg": 0.2,
        "why": why,
    }


def test_a_seed_that_never_settles_makes_the_row_null():
    rows = _aggregate([_run(0, 2.0), _run(1, None), _run(2, 3.0)])
    (row,) = rows
    assert row["settle_s"] is None and row["settle_s_reached"] == 2 and row["seeds"] == 3
    assert (
        row["rise_s"] == pytest.approx(1.0)
        and row["paper"]["settle_s"] == PAPER_TABLE3[("posterior-3", "capstan-nonsmooth", 1)][1]
    )
    ok = _aggregate([_run(0, 2.0), _run(1, 4.0)])[0]
    assert ok["settle_s"] == pytest.approx(3.0) and ok["settle_s_sd"] == pytest.approx(1.0)


def test_closed_loop_tests_give_the_json_floor_and_a_page(tmp_path):
    logs = load("snake12-paper", protocol="posterior-6", frames=600, progress=False)
    result = closed_loop_tests(
        "snake12-paper", {"oracle": None, "proximal": make("proximal").fit(logs)}, [0], ["posterior-6"]
    )
    rows = result["rows"]
    assert {(r["estimator"], r["loop"]) for r in rows} == {(e, lo) for e in ("oracle", "proximal") for lo in (1, 2)}
    for r in rows:
        assert r["regime"] == "posterior-6"
        for key in ("rise_s", "settle_s", "rms_deg"):
            assert r[key] is None or (isinstance(r[key], float) and np.isfinite(r[key]))
    oracle = [r for r in rows if r["estimator"] == "oracle"]
    assert all(r["settle_s"] is not None for r in oracle)  # the oracle settles every loop
    # The oracle's intermediate estimates carry the cells' 1 N noise alone; the proximal hypothesis
    # (no loss along the path) misses every guide's friction.
    proximal = [r for r in rows if r["estimator"] == "proximal"]
    for o, p in zip(oracle, proximal):
        assert o["why"]["intermediate_rmse_n"] < 1.5 < p["why"]["intermediate_rmse_n"]
        assert o["why"]["load_error_nm"] < p["why"]["load_error_nm"]
    result.update(recipe="snake12-paper", preset="fast", seconds=1.0, fit_seconds=0.0, benchmark="table3")
    json.dumps(result)  # plain JSON all the way down
    text = format_table3(result)
    assert "posterior-6" in text and "oracle" in text
    page = write_table3_page(result, tmp_path / "t3.html").read_text()
    assert "<img" in page and "Table III" in page and "proximal" in page
    assert "What intermediate accuracy buys" in page and "intermediate RMSE [N]" in page


@pytest.mark.slow
def test_benchmark_table3_cli(tmp_path, capsys):
    code = main(
        [
            "benchmark",
            "table3",
            "--repeats",
            "1",
            "--json",
            str(tmp_path / "t3.json"),
            "--out",
            str(tmp_path / "t3.html"),
        ]
    )
    assert code == 0
    doc = json.loads((tmp_path / "t3.json").read_text())
    assert doc["benchmark"] == "table3" and doc["preset"] == "fast" and doc["seconds"] > 0
    names = {r["estimator"] for r in doc["rows"]}
    assert names == {"pg-chtc", "capstan-nonsmooth", "pg-chtc-ns", "proximal", "oracle"}
    assert {r["regime"] for r in doc["rows"]} == {"posterior-3", "posterior-6"}


def test_a_planar_robots_figure_draws_theta_x_alone():
    from tendon_id.report.closed_loop import step_figure

    t = np.arange(0.0, 2.0, 0.1)
    traces = {
        "t": t.tolist(),
        "estimators": ["oracle"],
        "joints": [5, 6],
        "direction": [-1.0, 0.0],
        "amplitude_deg": 5.0,
        "lead_s": 0.5,
        "hold_s": 0.75,
        "bending_axes": 1,
        "ref_deg": np.zeros((len(t), 2, 2)).tolist(),
        "angles_deg": np.zeros((1, len(t), 2, 2)).tolist(),
    }
    assert len(step_figure({"posterior-3": traces}, "posterior-3").axes) == 1
    traces["bending_axes"] = 2
    assert len(step_figure({"posterior-3": traces}, "posterior-3").axes) == 2
