"""The zoo's contract: registry, fit/predict shapes, no intermediate truth read, save/load, constraints."""

import dataclasses
import json

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from tendon_id import zoo
from tendon_id.calibration.law import linear_design
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.sim import simulate
from tendon_id.zoo.inputs import TransmissionInputs
from tendon_id.zoo.snake.contract import scrambled_truth

ANALYTIC = ["proximal", "capstan-simple", "capstan-contact", "capstan-nonsmooth", "capstan-const-mu"]


@pytest.fixture(scope="module")
def data():
    r = load_recipe("snake12-paper")
    train = simulate(r, "posterior-6", frames=1000, seed=0).recording
    test = simulate(r, "planned-paths", frames=400, seed=1).recording
    return train, test


def test_registry_lists_every_hypothesis_and_rejects_unknowns():
    assert set(ANALYTIC) <= set(zoo.names())
    with pytest.raises(ConfigError, match="unknown model"):
        zoo.make("capstan-magic")
    with pytest.raises(ConfigError, match="no setting"):
        zoo.make("capstan-simple", bogus=1)
    with pytest.raises(ConfigError, match="tying"):
        zoo.make("capstan-simple", tying="sometimes").fit(
            simulate(load_recipe("snake12-paper"), "posterior-3", frames=200).recording
        )


@pytest.mark.parametrize("name", ANALYTIC)
@pytest.mark.parametrize("tying", ["tied", "per-guide"])
def test_fit_predict_shapes_and_contract(data, name, tying):
    train, test = data
    m = zoo.make(name) if name == "proximal" else zoo.make(name, tying=tying, n_starts=1, maxeval=60)
    assert m.fit(train) is m  # fit returns self
    pred = m.predict(test)
    chain = m.predict_chain(test)
    n = test.n_modules
    assert pred.shape == (test.n_frames, n, 3)
    assert chain.shape == (test.n_frames, n, n, 3)
    np.testing.assert_allclose(chain[:, np.arange(n), np.arange(n)], pred, rtol=1e-12)
    np.testing.assert_array_equal(pred[:, 0], test.actuator[:, 0])  # set 1 passes no guide
    assert np.all(np.isnan(chain[:, np.arange(n)[:, None] > np.arange(n)[None, :]]))
    # predict has no side effects
    before = {k: v.copy() if isinstance(v, np.ndarray) else v for k, v in vars(m).items()}
    m.predict(test)
    for k, v in vars(m).items():
        if isinstance(v, np.ndarray):
            np.testing.assert_array_equal(v, before[k])
    s = m.score(test)
    assert set(s["terminal"]) == {"rmse", "r2", "max_error"}
    assert len(s["joints"]["per_joint"]) == n


@pytest.mark.parametrize("name", ANALYTIC)
def test_save_load_predict_is_identical_and_pickle_free(data, tmp_path, name):
    train, test = data
    m = zoo.make(name).fit(train) if name == "proximal" else zoo.make(name, n_starts=1, maxeval=60).fit(train)
    folder = m.save(tmp_path / name)
    assert sorted(p.name for p in folder.iterdir()) == ["arrays.npz", "model.json"]
    json.loads((folder / "model.json").read_text())  # plain JSON
    with np.load(folder / "arrays.npz", allow_pickle=False) as npz:  # loads without pickle
        assert all(npz[k].dtype != object for k in npz.files)
    back = zoo.load(folder)
    assert type(back) is type(m) and back.get_params().keys() == m.get_params().keys()
    np.testing.assert_array_equal(back.predict(test), m.predict(test))
    np.testing.assert_array_equal(back.predict_chain(test), m.predict_chain(test))


@pytest.mark.parametrize("name", ANALYTIC[1:])
def test_scrambling_intermediate_truth_changes_no_fitted_parameter(data, name):
    train, _ = data
    a = zoo.make(name, n_starts=2, maxeval=80).fit(train)
    b = zoo.make(name, n_starts=2, maxeval=80).fit(scrambled_truth(train, 1))
    np.testing.assert_array_equal(a.A_, b.A_)
    np.testing.assert_array_equal(a.B_, b.B_)


def test_smooth_calibration_matches_an_independent_scipy_solution():
    # Noise-only data with an interior optimum (the bounds |A|, B <= 2 are not active).
    train = simulate(load_recipe("snake12-noise-only"), "terminal-only", frames=3000, seed=0).recording
    for tying in ("tied", "per-guide"):
        m = zoo.make("capstan-contact", tying=tying, xtol_rel=1e-12).fit(train)
        X, Y = linear_design(m, TransmissionInputs.from_recordings(train.fitting_view()))
        g = X.shape[1] // 2
        # B >= |A|  <=>  u = B - A >= 0, v = B + A >= 0: a box-constrained linear least squares.
        T = np.block([[-0.5 * np.eye(g), 0.5 * np.eye(g)], [0.5 * np.eye(g), 0.5 * np.eye(g)]])  # (A, B) = T (u, v)
        for i in range(3):
            ref = lsq_linear(X @ T, Y[:, i], bounds=(0.0, 4.0), tol=1e-14, lsmr_tol="auto", max_iter=10000)
            theta = T @ ref.x
            ours = np.r_[m.A_[:, i], m.B_[:, i]]
            sse = lambda th: float(np.sum((Y[:, i] - X @ th) ** 2))  # noqa: E731
            assert sse(ours) <= sse(theta) * (1 + 1e-6) + 1e-12
            if tying == "tied":
                np.testing.assert_allclose(ours, theta, atol=1e-5)


def test_constraint_holds_on_data_that_pushes_against_it():
    # Truth with B << |A| (mu < 0 beyond ~100 deg) and large wraps: the unconstrained optimum
    # is infeasible, so every calibrated law must sit on or inside B = |A|.
    r = load_recipe("snake12-paper")
    r = dataclasses.replace(r, friction=dataclasses.replace(r.friction, A=(0.6, 0.55, 0.5), B=(0.02, 0.01, 0.03)))
    rec = simulate(r, "planned-paths", effects="none", frames=800, seed=2).recording
    for name in ANALYTIC[1:]:
        for tying in ("tied", "per-guide"):
            m = zoo.make(name, tying=tying, n_starts=2, maxeval=100).fit(rec)
            assert np.all(m.B_ >= np.abs(m.A_)), (name, tying)


@pytest.mark.xfail(
    reason="on a fresh install of 2026-11-28 (numpy 2.4.6, scipy 1.17.1, nlopt 2.11.0, numba 0.68.1) tendon 3's "
    "mu(0) comes out 0.362 against 0.39, at commit 2367806 too: a dependency change, not issue 41 (noted on the issue)",
    strict=False,
)
def test_nonsmooth_recovers_a_known_law_when_its_structure_is_right():
    # The model's structure is the simulator's (the dead zone of the recipe's contact, the play operator,
    # fresh pretension at each trajectory start), and it fits the clearance and the routing wrap too.
    # Load-cell noise is small here because a play operator fed with noisy inputs ratchets on the
    # noise and biases mu upwards (about 1-4 % at 1 N): an errors-in-variables effect of the
    # nonsmooth model, documented in tendon_id.calibration.
    r = load_recipe("snake12-noise-only")
    r = dataclasses.replace(r, session="fresh", sensors=dataclasses.replace(r.sensors, noise_n=0.05))
    assert r.effects.get("contact").gate == zoo.ContactGate().gate == "dead_zone"
    rec = simulate(r, "posterior-3", effects="contact,stick_slip", frames=2000, seed=3).recording
    m = zoo.make("capstan-nonsmooth").fit(rec)
    truth = np.array(r.friction.A) + np.array(r.friction.B)
    np.testing.assert_allclose(m.mu0_[0], truth, rtol=0.02)
    # Measured: 0.0803 and 0.0505 rad, from starts of 0.0997 and 0.
    assert m.alpha_c_ == pytest.approx(r.robot.alpha_c, abs=0.003)
    assert m.alpha_0_ == pytest.approx(r.robot.alpha_0, abs=0.003)


def test_blocks_compose_and_free_parameters_are_calibrated():
    r = load_recipe("snake12-noise-only")
    rec = simulate(r, "posterior-3", effects="sensor_bias", frames=1500, seed=4).recording
    base = zoo.make("capstan-simple").fit(rec)
    biased = base.with_blocks(zoo.SensorBias(offset=0.0, gain=0.0, drift=0.0)).set_params(n_starts=1, maxeval=300)
    biased.fit(rec)
    assert biased.block_values_["sensor_bias"].keys() == {"offset", "gain", "drift"}
    assert biased.score(rec)["terminal"]["rmse"] < base.score(rec)["terminal"]["rmse"]


def test_unfitted_and_mismatched_use_is_a_clear_error(data):
    train, _ = data
    with pytest.raises(zoo.NotFittedError):
        zoo.make("capstan-simple").predict(train)
    m = zoo.make("proximal").fit(train)
    small = simulate(load_recipe("snake12-paper"), "single-passage", frames=100).recording
    with pytest.raises(ConfigError, match="modules"):
        m.predict(small)
    with pytest.raises(ConfigError, match="no model.json"):
        zoo.load("/nonexistent/folder")
