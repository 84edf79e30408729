"""Single-passage data: mapping files, units, the passage-capstan model, and the real bench (skipped without it)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from passage_data import BENCH, TRUE, tendon_passage

from tendon_id import zoo
from tendon_id.cli import main
from tendon_id.data.mapping import load_mapping, read_files
from tendon_id.data.passage import PassageRecording
from tendon_id.data.units import si_factor
from tendon_id.errors import ConfigError
from tendon_id.zoo.estimator import NotFittedError
from tendon_id.zoo.passage import PassageCapstan, PassageModel
from tendon_id.zoo.testing import check_model


def test_units_convert_to_si_and_refuse_the_wrong_dimension():
    assert si_factor("deg", "angle", where="m") == pytest.approx(np.pi / 180, rel=1e-15)
    assert si_factor("turn / 8192", "angle", where="m") == pytest.approx(2 * np.pi / 8192, rel=1e-15)
    assert si_factor("mN", "tension", where="m") == pytest.approx(1e-3, rel=1e-15)
    assert si_factor("N·m", "torque", where="m") == 1.0
    assert si_factor("ms", "time", where="m") == pytest.approx(1e-3)
    for unit, kind, words in [
        ("furlongs_per_blorp", "tension", "unknown unit"),
        ("mN", "torque", "torque"),
        ("count", "angle", "not an angle"),
    ]:
        with pytest.raises(ConfigError, match=words):
            si_factor(unit, kind, where="m.toml: columns.x")


FOREIGN = """
kind = "passage"
quantity = "tension"
[file]
comment = "#"
[columns]
t = {{ column = "time_ms", unit = "ms" }}
input = {{ column = "F motor", unit = "mN" }}
output = {{ column = "F tip", unit = "{out_unit}", sign = {sign} }}
position = {{ column = "motor angle", unit = "deg" }}
"""


def _write_foreign(rec: PassageRecording, path: Path) -> None:
    """``rec`` as a user's CSV: ms, mN, degrees, other column names and a comment line."""
    f = rec.frame
    foreign = pd.DataFrame(
        {
            "time_ms": f["t"] * 1e3,
            "F motor": f["input"] * 1e3,
            "F tip": f["output"] * 1e3,
            "motor angle": np.degrees(f["position"]),
        }
    )
    path.write_text("# logged by a bench\n" + foreign.to_csv(index=False, float_format="%.17g"))


def test_a_foreign_csv_and_its_mapping_give_the_same_fit_as_si(tmp_path):
    recs = [tendon_passage(s) for s in range(3)]
    si = []
    for k, r in enumerate(recs):
        r.write(tmp_path / f"si{k}.parquet")
        _write_foreign(r, tmp_path / f"run{k}.csv")
        si.append(PassageRecording.read(tmp_path / f"si{k}.parquet"))
    (tmp_path / "map.toml").write_text(FOREIGN.format(out_unit="mN", sign=1))
    mapped = read_files([tmp_path / f"run{k}.csv" for k in range(3)], load_mapping(tmp_path / "map.toml"))
    assert [m.trajectories for m in mapped] == [["run0"], ["run1"], ["run2"]]
    np.testing.assert_allclose(mapped[0].output, si[0].output, rtol=1e-12)
    a = PassageCapstan(blocks=("stick_slip",), warmup_s=0.5).fit(si[:2])
    b = PassageCapstan(blocks=("stick_slip",), warmup_s=0.5).fit(mapped[:2])
    for k in a.theta_:
        assert b.theta_[k] == pytest.approx(a.theta_[k], rel=1e-9, abs=1e-12), k
    assert a.theta_["phi"] == pytest.approx(TRUE["phi"], abs=0.02)  # and the physics is recovered
    assert a.score(si[2])["predicted"]["rmse"] < 0.1


@pytest.mark.parametrize(
    "edit, words",
    [
        (lambda t: t.replace('unit = "mN", sign = 1', 'unit = "blorpnewton", sign = 1'), "unknown unit"),
        (lambda t: t.replace('"F tip"', '"F tipp"'), "no column 'F tipp'"),
        (lambda t: t.replace("sign = 1", "sign = -1"), "not positive"),
        # Found by the mapping fuzz: column numbers count from 1, so -4 is no column (it was an IndexError).
        (lambda t: t.replace('comment = "#"', 'comment = "#"\ntrajectory = -4'), "number from 1, got -4"),
        (lambda t: t.replace('comment = "#"', 'comment = "#"\ntrajectory = 0'), "number from 1, got 0"),
    ],
)
def test_bad_mappings_exit_2_with_one_line(tmp_path, capsys, edit, words):
    _write_foreign(tendon_passage(0, n=200), tmp_path / "run.csv")
    (tmp_path / "map.toml").write_text(edit(FOREIGN.format(out_unit="mN", sign=1)))
    code = main(["info", "--mapping", str(tmp_path / "map.toml"), str(tmp_path / "run.csv")])
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and words in lines[0] and "Traceback" not in err, err


@pytest.mark.parametrize("name", zoo.names_of(PassageModel))
def test_every_passage_model_keeps_the_zoo_contract(name):
    train, test = PassageRecording.concat([tendon_passage(s, n=400) for s in (0, 1)]), tendon_passage(2, n=300)
    check_model(zoo.make(name, warmup_s=0.5, blocks=("stick_slip", "smooth_edge")), train, test)


def test_the_passage_model_keeps_the_estimator_contract(tmp_path):
    train, test = [tendon_passage(s, n=600) for s in (0, 1)], tendon_passage(2, n=600)
    model = PassageCapstan(blocks=("stick_slip", "smooth_edge"), warmup_s=0.5)
    with pytest.raises(NotFittedError):
        model.predict(test)
    assert model.fit(train) is model
    pred = model.predict(test)
    assert pred.shape == (test.n_frames,) and np.isfinite(pred).all()
    frame = test.frame.copy()
    assert model.predict(test).tobytes() == pred.tobytes() and test.frame.equals(frame)
    back = zoo.load(model.save(tmp_path / "m"))
    assert type(back) is PassageCapstan and back.predict(test).tobytes() == pred.tobytes()
    assert json.loads((tmp_path / "m" / "model.json").read_text())["model"] == "passage-capstan"
    torque = PassageRecording(test.frame, {"quantity": "torque"})
    with pytest.raises(ConfigError, match="tension passage"):
        model.predict(torque)
    with pytest.raises(ConfigError, match="refines stick_slip"):
        PassageCapstan(blocks=("smooth_edge",)).fit(train)


def test_the_inverse_direction_predicts_the_input():
    recs = [tendon_passage(s, n=600, blocks=()) for s in range(3)]  # slip follows the motion
    model = PassageCapstan(direction="inverse", warmup_s=0.5).fit(recs[:2])
    score = model.score(recs[2])
    assert score["side"] == "input" and score["predicted"]["r2"] > 0.9
    assert model.theta_["phi"] == pytest.approx(TRUE["phi"], abs=0.02)
    # A warm-up longer than the data's trajectories leaves nothing to score: an error, not a crash
    # in the metrics (found by the model-file fuzz: a saved warmup_s raised past the data's length).
    longest = recs[2].n_frames * recs[2].dt
    model.set_params(warmup_s=2 * longest)
    with pytest.raises(ConfigError, match=f"leaves no frame to score: the longest trajectory lasts {longest:g} s"):
        model.score(recs[2])


@pytest.mark.skipif(not BENCH.is_dir(), reason="../shared/data/real is not here")
def test_the_shipped_mapping_reads_the_bench_in_si():
    files = sorted((BENCH / "Tool_4_Maryland_L_2").glob("*.TXT"))[:2]
    recs = read_files(
        files, load_mapping(Path(__file__).resolve().parents[1] / "datasets/mappings/mis-tool-characterization.toml")
    )
    r = recs[0]
    assert r.quantity == "torque" and r.sample_rate_hz == pytest.approx(1000.0)
    assert r.trajectories == [files[0].stem]
    # The jaw's torque is in phase with the spindle's (positive), and within the sensor's range.
    assert 0 < np.median(r.output) < 0.1 and np.abs(r.input).max() < 0.2
