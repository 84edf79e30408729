"""A passage's calibration through nlopt, its emcee posterior, and ``tendon-id calibrate`` on a passage."""

from __future__ import annotations

import json

import numpy as np
import pytest
from passage_data import TRUE, tendon_passage

from tendon_id.calibration.posterior import sample_posterior
from tendon_id.cli import main
from tendon_id.zoo.passage import PassageCapstan
from tendon_id.zoo.passage.fitting import confounded_groups


@pytest.fixture(scope="module")
def fitted():
    recs = [tendon_passage(s) for s in range(2)]
    return recs, PassageCapstan(blocks=("stick_slip",), warmup_s=0.5).fit(recs)


def test_nlopt_recovers_the_law_and_reports_its_stop(fitted):
    _, model = fitted
    assert model.theta_["gain"] == pytest.approx(TRUE["gain"], rel=2e-3)
    assert model.theta_["phi"] == pytest.approx(TRUE["phi"], abs=2e-3)
    assert model.calibration_["status"] in ("xtol_reached", "ftol_reached", "success")
    assert model.calibration_["rmse"] == pytest.approx(0.05, rel=0.1)  # the noise the data was made with


def test_the_posterior_covers_the_truth_and_sees_white_noise(fitted):
    recs, model = fitted
    post = sample_posterior(model, recs, max_steps=1200, target_ess=200, seed=3, progress=False)
    summary = post.statistics()
    for name in ("gain", "phi", "offset"):
        assert summary[name]["q2.5"] <= TRUE[name] <= summary[name]["q97.5"], name
    assert post.residual_tau < 3.0  # the residual is the added white noise
    assert np.exp(summary["log_sigma"]["mean"]) == pytest.approx(0.05, rel=0.1)
    again = sample_posterior(model, recs, max_steps=1200, target_ess=200, seed=3, progress=False)
    assert np.array_equal(post.chain, again.chain)  # the same seed, the same chain


def test_a_correlated_residual_widens_the_posterior(fitted):
    """A base without stick/slip leaves a slow model error: its effective frames are fewer than its frames."""
    recs, _ = fitted
    base = PassageCapstan(warmup_s=0.5).fit(recs)
    post = sample_posterior(base, recs, max_steps=400, target_ess=50, seed=0, progress=False)
    assert post.residual_tau > 5.0
    assert post.to_dict()["residual_tau_frames"] == post.residual_tau


def test_confounded_groups_join_chains_of_strong_correlations():
    corr = np.eye(4)
    corr[0, 1] = corr[1, 0] = 0.999
    corr[1, 2] = corr[2, 1] = -0.995
    assert confounded_groups(["a", "b", "c", "d"], corr) == [["a", "b", "c"]]
    assert confounded_groups(["a", "b", "c", "d"], np.eye(4)) == []


def test_calibrate_a_passage_from_the_cli(fitted, tmp_path, capsys):
    recs, _ = fitted
    paths = []
    for k, r in enumerate(recs):
        paths += ["--data", str(r.write(tmp_path / f"run{k}.parquet"))]
    code = main(
        ["calibrate", "--model", "passage-capstan", "--blocks", "stick_slip", *paths, "--out", str(tmp_path / "c")]
    )
    out = capsys.readouterr().out
    assert code == 0, out
    doc = json.loads((tmp_path / "c" / "calibration.json").read_text())
    assert doc["blocks"] == ["stick_slip"] and doc["unit"] == "N" and doc["side"] == "output"
    assert doc["theta"]["phi"] == pytest.approx(TRUE["phi"], abs=2e-3)
    assert "output RMSE" in out


@pytest.mark.parametrize(
    "args, words",
    [
        (["--blocks", "stick_slip,nope"], "unknown passage effect 'nope'"),
        (["--tying", "per-guide"], "--tying: no setting of model 'passage-capstan'"),
    ],
)
def test_calibrate_refuses_a_passage_misuse_with_exit_2(fitted, tmp_path, capsys, args, words):
    recs, _ = fitted
    path = recs[0].write(tmp_path / "run.parquet")
    code = main(["calibrate", "--model", "passage-capstan", *args, "--data", str(path), "--out", str(tmp_path / "c")])
    err = capsys.readouterr().err
    assert code == 2 and words in err and "Traceback" not in err


def test_run_calibration_of_a_passage_needs_no_report(fitted, tmp_path):
    """The library call prints nothing unless asked (it once called a missing ``report`` on this path)."""
    from tendon_id.report.calibration import run_calibration

    recs, _ = fitted
    written = run_calibration(recs, model="passage-capstan", settings={"blocks": ["stick_slip"]}, out=tmp_path)
    doc = json.loads((tmp_path / "calibration.json").read_text())
    assert written[0] == tmp_path / "calibration.json" and doc["blocks"] == ["stick_slip"]
    assert doc["theta"]["gain"] == pytest.approx(TRUE["gain"], rel=5e-3)
