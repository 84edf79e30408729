"""Robots that are not the paper's, end to end: 4 tendons per set (snake6-quad) and a planar pair (planar6-pair).

Each bundled recipe is simulated, and the capstan family keeps the zoo's whole contract on it
(:func:`tendon_id.zoo.testing.check_model`: shapes with the robot's tendon count, terminal labels
only, save and load to the bit); calibration, its posterior, the identifiability study and the
diagnosis run and give one answer per tendon. The cascades on these robots: tests/zoo/test_learned_tendons.py.
"""

import numpy as np
import pytest

from tendon_id import zoo
from tendon_id.calibration.posterior import sample_posterior
from tendon_id.datasets import load_recipe
from tendon_id.diagnosis import DiagnosisSettings, diagnose
from tendon_id.identifiability import StudySettings, analyse
from tendon_id.sim import simulate
from tendon_id.zoo.testing import check_model

ROBOTS = {"snake6-quad": 4, "planar6-pair": 2}
QUICK = StudySettings(n_chains=16, n_steps=60, thin=5, band_frames=200, emcee=False, check_advice=False)


@pytest.fixture(scope="module", params=sorted(ROBOTS))
def robot(request):
    recipe = load_recipe(request.param)
    train = simulate(recipe, "posterior-3", frames=800, seed=0).recording
    test = simulate(recipe, "posterior-6", frames=400, seed=1).recording
    return request.param, train, test


def test_the_recording_has_the_robots_tendons(robot):
    name, train, _ = robot
    n = ROBOTS[name]
    assert train.n_tendons == n
    assert train.actuator.shape == (train.n_frames, 6, n)
    assert train.terminal.shape == (train.n_frames, n)
    assert train.joint_truth.shape == (train.n_frames, 6, n)
    assert train.meta["robot"]["n_tendons"] == n
    if name == "planar6-pair":
        # A hinge moves only in its plane (towards x): theta_y stays zero, theta_x does not.
        assert np.all(train.angles[..., 1] == 0.0)
        assert np.abs(train.angles[..., 0]).max() > np.radians(2.0)


@pytest.mark.parametrize("model", ["proximal", "capstan-simple", "capstan-nonsmooth"])
def test_the_capstan_family_keeps_the_contract(robot, model):
    _, train, test = robot
    check_model(zoo.make(model), train, test)


def test_a_model_refuses_data_of_another_tendon_count(robot):
    name, train, _ = robot
    other = simulate(load_recipe("planar6-pair" if name == "snake6-quad" else "snake6-quad"), "posterior-3", frames=200)
    model = zoo.make("capstan-simple").fit(train)
    with pytest.raises(Exception, match="tendons per set"):
        model.predict(other.recording)


def test_calibration_and_posterior_have_one_law_per_tendon(robot):
    name, train, _ = robot
    n = ROBOTS[name]
    model = zoo.make("capstan-contact").fit(train)
    assert model.A_.shape == (1, n) and model.B_.shape == (1, n)
    assert np.all(model.B_ >= np.abs(model.A_))  # the feasible set of the calibration (B >= |A|)
    post = sample_posterior(model, train, target_ess=50.0, max_steps=400, seed=0, encoder_bits=None, progress=False)
    A, B = post.law_samples()
    assert A.shape[1:] == (1, n) and B.shape == A.shape
    assert [f"A_{i}" for i in range(1, n + 1)] == [p for p in post.names if p.startswith("A_")]


def test_identifiability_studies_every_tendon(robot):
    name, train, _ = robot
    n = ROBOTS[name]
    result = analyse(train.fitting_view(), QUICK, progress=False)
    tied = result.studies["tied"]
    assert len(tied.spectra) == n and len(tied.draws) == n
    assert tied.n_params == n * tied.problem.n_params


def test_the_diagnosis_ranks_candidates(robot):
    name, train, test = robot
    n = ROBOTS[name]
    result = diagnose(
        zoo.make("capstan-nonsmooth"),
        train,
        test,
        candidates=["sensor_bias", "actuator_cells"],
        settings=DiagnosisSettings(folds=2, n_boot=50),
        progress=False,
    )
    assert {c.effect for c in result.candidates} == {"sensor_bias", "actuator_cells"}
    assert all(np.isfinite(c.heldout_rmse) for c in result.candidates)
    cells = next(c for c in result.candidates if c.effect == "actuator_cells")
    # One gain and one offset per tendon of the robot's sets.
    assert sorted(cells.params) == sorted(
        [f"gain_{i}" for i in range(1, n + 1)] + [f"offset_{i}" for i in range(1, n + 1)]
    )
