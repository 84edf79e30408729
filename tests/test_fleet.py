"""A fleet: many recordings calibrated at once, one result per file, the same bytes on any number of
workers and on a Dask cluster (issue 42, deliver 6)."""

import json
import re

import pytest
from passage_data import tendon_passage

import tendon_id.report.fleet as fleet_module
from tendon_id.data.mapping import read_files
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError, RecordingError
from tendon_id.report.calibration import run_calibration
from tendon_id.report.fleet import calibrate_fleet, fleet_names
from tendon_id.sim import simulate

# Seeded random starts (capstan-nonsmooth), cut short: quick, and the seed still matters.
MODEL, SETTINGS = "capstan-nonsmooth", {"maxeval": 100}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Three small recordings, two of them with one stem in two folders."""
    root = tmp_path_factory.mktemp("fleet-data")
    (root / "day2").mkdir()
    paths = [root / "a.parquet", root / "b.parquet", root / "day2" / "a.parquet"]
    for seed, path in enumerate(paths):
        simulate(load_recipe("snake12-paper"), "posterior-6", frames=240 + 60 * seed, seed=seed).recording.write(path)
    return paths


def _timeless(text: str) -> str:
    """A JSON text with its wall times zeroed: the only numbers that may differ between two runs."""
    return re.sub(r'"seconds": [0-9.eE+-]+', '"seconds": 0', text)


def _contents(folder):
    """Every file under ``folder``: relative path -> bytes, wall times zeroed in the JSON."""
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            data = p.read_bytes()
            out[p.relative_to(folder).as_posix()] = _timeless(data.decode()) if p.suffix == ".json" else data
    return out


def test_names_are_stems_made_unique_case_blind():
    assert fleet_names(["x/a.csv", "y/a.csv", "b.csv", "z/A.parquet", "a-2.csv"]) == ["a", "a-2", "b", "A-3", "a-2-2"]
    assert fleet_names(["fleet.json.csv"]) == ["fleet.json-2"]  # never the summary's place


def test_each_file_gets_the_result_it_gets_alone(files, tmp_path):
    doc = calibrate_fleet(files, model=MODEL, settings=SETTINGS, out=tmp_path / "fleet", n_jobs=1)
    assert [e["name"] for e in doc["entries"]] == ["a", "b", "a-2"]
    assert [e["frames"] for e in doc["entries"]] == [240, 300, 360]
    assert doc["ok"] == 3 and doc["refused"] == doc["failed"] == 0
    assert all(e["status"] == "ok" and e["unit"] == "N" and e["rmse"] > 0 and e["loss"] > 0 for e in doc["entries"])
    assert json.loads((tmp_path / "fleet" / "fleet.json").read_text()) == doc
    alone = tmp_path / "alone"
    run_calibration(read_files([files[2]]), model=MODEL, settings=SETTINGS, out=alone)
    assert _contents(alone) == _contents(tmp_path / "fleet" / "a-2")  # calibration.json, model/ as calibrate writes


def test_the_same_seed_gives_the_same_bytes_on_one_or_two_workers(files, tmp_path):
    one = calibrate_fleet(files, model=MODEL, settings=SETTINGS, out=tmp_path / "one", seed=3, n_jobs=1)
    two = calibrate_fleet(files, model=MODEL, settings=SETTINGS, out=tmp_path / "two", seed=3, n_jobs=2)
    assert _contents(tmp_path / "one") == _contents(tmp_path / "two")
    assert _timeless(json.dumps(one)) == _timeless(json.dumps(two))
    calibrate_fleet(files[:1], model=MODEL, settings=SETTINGS, out=tmp_path / "other", seed=4)
    seeded = [
        json.loads((tmp_path / d / "a" / "calibration.json").read_text())["calibration"] for d in ("one", "other")
    ]
    assert seeded[0]["n_eval"] != seeded[1]["n_eval"]  # the seed does reach the multi-start's random starts


def test_bad_files_are_named_before_any_fit(files, tmp_path, monkeypatch):
    def never(*args, **kwargs):
        raise AssertionError("a fit started before every file was read")

    monkeypatch.setattr(fleet_module, "calibrate_one", never)
    bad, foreign = tmp_path / "bad.csv", tmp_path / "passage.csv"
    bad.write_text("not,a\nrecording,at all\n")
    tendon_passage(0, n=200).write(foreign)
    with pytest.raises(RecordingError, match=r"bad\.csv.*1 more files cannot be calibrated: .*passage\.csv"):
        calibrate_fleet([files[0], bad, foreign], model=MODEL, out=tmp_path / "out")
    with pytest.raises(RecordingError, match=r"passage\.csv: .*expected snake chain recordings"):
        calibrate_fleet([files[0], foreign], model=MODEL, out=tmp_path / "out")
    with pytest.raises(ConfigError, match="n_jobs"):
        calibrate_fleet(files, model=MODEL, out=tmp_path / "out", n_jobs=0)
    assert not (tmp_path / "out").exists()


def test_a_file_refused_at_fit_time_is_recorded_and_the_others_kept(files, tmp_path, monkeypatch):
    real = fleet_module.fit_calibration

    def fit(recordings, **kwargs):
        if recordings[0].n_frames == 300:
            raise RecordingError("too few slipping frames to calibrate", file="b.parquet")
        m, doc = real(recordings, **kwargs)
        if recordings[0].n_frames == 360:
            doc["terminal"]["rmse"] = float("nan")
        return m, doc

    monkeypatch.setattr(fleet_module, "fit_calibration", fit)
    doc = calibrate_fleet(files, model=MODEL, settings=SETTINGS, out=tmp_path / "f", n_jobs=1)
    assert [e["status"] for e in doc["entries"]] == ["ok", "refused", "refused"]
    assert doc["entries"][1]["reason"] == "b.parquet: too few slipping frames to calibrate"
    assert doc["entries"][2]["reason"] == "the calibration is not finite (rmse)"
    assert (tmp_path / "f" / "a" / "calibration.json").is_file()
    assert not (tmp_path / "f" / "b").exists() and not (tmp_path / "f" / "a-2").exists()


def test_a_bench_fleet_gives_each_file_its_rmse_in_its_unit(tmp_path):
    paths = [tmp_path / "run0.csv", tmp_path / "run1.csv"]
    for seed, path in enumerate(paths):
        tendon_passage(seed, n=600).write(path)
    doc = calibrate_fleet(paths, model="passage-capstan", settings={"blocks": ["stick_slip"]}, out=tmp_path / "f")
    assert [(e["status"], e["unit"], e["loss"]) for e in doc["entries"]] == [("ok", "N", None)] * 2
    for e in doc["entries"]:
        cal = json.loads((tmp_path / "f" / e["name"] / "calibration.json").read_text())
        assert e["rmse"] == cal["predicted"]["rmse"] < 0.5  # on tensions of about 30 N


def test_the_fleet_runs_unchanged_on_a_dask_cluster(files, tmp_path):
    distributed = pytest.importorskip("distributed")
    from joblib import parallel_config

    serial = calibrate_fleet(files, model=MODEL, settings=SETTINGS, out=tmp_path / "serial", seed=1)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        with distributed.Client(cluster) as client, parallel_config(backend="dask"):
            with distributed.get_task_stream(client) as tasks:
                on_dask = calibrate_fleet(files, model=MODEL, settings=SETTINGS, out=tmp_path / "dask", seed=1)
    assert tasks.data  # the jobs ran on the cluster's workers (threads here: quick to start)
    assert _timeless(json.dumps(on_dask)) == _timeless(json.dumps(serial))
    assert _contents(tmp_path / "dask") == _contents(tmp_path / "serial")
