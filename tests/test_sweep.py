"""The Section IV-B sensitivity sweep (`tendon-id benchmark sweep`) on a small split, tiny preset."""

import json
import math
import threading

import pytest
from joblib import register_parallel_backend
from joblib._parallel_backends import ThreadingBackend

from tendon_id.benchmarks import sweep as sweep_mod
from tendon_id.benchmarks.registry import format_table
from tendon_id.benchmarks.splits import TEST_PROTOCOLS, PaperSplit
from tendon_id.cli import main
from tendon_id.datasets import load
from tendon_id.errors import ConfigError

USED = {"configured": 0, "threads": set()}


class RecordingThreads(ThreadingBackend):
    """joblib's threading backend, noting that it was asked for."""

    def configure(self, *args, **kwargs):
        USED["configured"] += 1
        return super().configure(*args, **kwargs)


register_parallel_backend("sweep-test-threads", RecordingThreads)


@pytest.fixture(scope="module")
def small_split():
    # 7 posterior-6 trajectories of 125 frames: 3 train, 1 validation, 1 test per protocol.
    rec = load("snake12-paper", protocol="posterior-6", frames=875, progress=False)
    ids = list(rec.trajectories)
    assert len(ids) == 7
    test = {p: rec.select([ids[4 + i]]) for i, p in enumerate(TEST_PROTOCOLS)}
    return PaperSplit(train=rec.select(ids[:3]), val=rec.select([ids[3]]), test=test)


@pytest.fixture
def patched(monkeypatch, small_split):
    def fake_paper_split(recipe, seed=0, *, progress=None):
        USED["threads"].add(threading.current_thread().name)
        return small_split

    monkeypatch.setattr(sweep_mod, "paper_split", fake_paper_split)
    return small_split


def test_grids_are_log_spaced_and_hold_the_operating_point():
    assert sweep_mod.grid("window", 5) == [5, 10, 20, 40, 80]
    assert sweep_mod.grid("eta_w", 3) == [0.25, 2.0, 16.0]
    assert sweep_mod.grid("lam", 2) == [0.03, 1.0, 30.0]
    for p, (lo, hi) in sweep_mod.RANGES.items():
        for n in (2, 4, 5, 7):
            g = sweep_mod.grid(p, n)
            assert g[0] == lo and g[-1] == hi and sweep_mod.OPERATING_POINT[p] in g and g == sorted(set(g))
    with pytest.raises(ConfigError):
        sweep_mod.grid("lam", 1)
    with pytest.raises(ConfigError):
        sweep_mod.grid("nope", 5)


def test_jobs_are_top_level_functions_for_remote_workers():
    # A job travels to a Dask or Ray worker by reference (module + name), so it must be a
    # module-level function that the worker can import back.
    import importlib

    job = sweep_mod.sweep_job
    assert job.__qualname__ == job.__name__ == "sweep_job"
    assert getattr(importlib.import_module(job.__module__), job.__name__) is job


def test_sweep_shape_ratios_and_backend(patched):
    USED["configured"], USED["threads"] = 0, set()
    res = sweep_mod.sweep(
        recipe="snake12-paper",
        preset="tiny",
        points=2,
        params=("lam",),
        backend="sweep-test-threads",
        n_jobs=2,
        progress=False,
    )
    # the backend option reached joblib, and jobs ran on its worker threads
    assert USED["configured"] >= 1
    assert USED["threads"] - {threading.main_thread().name}
    json.loads(json.dumps(res))  # plain JSON
    assert res["benchmark"] == "sweep" and res["preset"] == "tiny" and res["recipe"] == "snake12-paper"
    assert res["seconds"] > 0 and res["trained"] == 3
    assert [r["value"] for r in res["rows"]] == [0.03, 1.0, 30.0]
    for r in res["rows"]:
        assert r["method"] == "pg-chtc" and r["protocol"] == "overall" and r["parameter"] == "lam"
        assert set(r["terminal"]) >= {"rmse", "r2", "max_error"}
        assert math.isfinite(r["terminal"]["rmse"]) and math.isfinite(r["validation_rmse"])
        assert r["joints"] is not None and math.isfinite(r["joints"]["rmse"])
        assert r["settings"]["lam"] == r["value"] and r["settings"]["window"] == 20
    assert [r["operating_point"] for r in res["rows"]] == [False, True, False]
    assert set(res["ratios"]) == {"lam"} and res["ratios"]["lam"] >= 1.0 and res["test_ratios"]["lam"] >= 1.0
    vals = [r["validation_rmse"] for r in res["rows"]]
    assert res["ratios"]["lam"] == pytest.approx(max(vals) / min(vals))
    table = format_table(res)
    assert "lambda" in table and "worst/best" in table and "1.18" in table


def test_operating_point_is_trained_once_and_bad_backend_is_a_config_error(patched, monkeypatch):
    calls = []
    monkeypatch.setattr(sweep_mod, "sweep_job", lambda recipe, seed, preset, p, v: calls.append((p, v)) or _fake(p, v))
    res = sweep_mod.sweep(preset="tiny", points=3, backend="threading", progress=False)
    assert len(calls) == 4 * 2 + 1 == res["trained"] and len(res["rows"]) == 12
    assert set(res["ratios"]) == {"lam", "lam_s", "eta_w", "window"}
    with pytest.raises(ConfigError):
        sweep_mod.sweep(preset="tiny", points=2, params=("lam",), backend="no-such-backend", progress=False)


def _fake(p, v):
    m = {"rmse": 1.0 + abs(math.log(v / sweep_mod.OPERATING_POINT[p])), "r2": 0.5, "max_error": 3.0}
    return {
        "settings": sweep_mod._settings(p, v),
        "validation": m,
        "terminal": m,
        "joints": None,
        "test": {},
        "frames": {},
        "seconds": 0.0,
    }


def test_cli_has_the_sweep_options(capsys):
    assert main(["benchmark", "--help"]) == 0
    out = capsys.readouterr().out
    assert "--backend" in out and "--jobs" in out and "--points" in out
