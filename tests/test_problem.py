"""The law problem: one design, one weight and one layout for calibration, posterior and identifiability."""

import os
import subprocess
import sys

import numpy as np
import pytest

from tendon_id import identifiability
from tendon_id.calibration import problem as problem_module
from tendon_id.calibration.law import calibrate
from tendon_id.calibration.law_layout import LawLayout
from tendon_id.calibration.mcmc import ess_rhat
from tendon_id.calibration.posterior import sample_posterior
from tendon_id.calibration.problem import LawProblem, constrained_lstsq, delta_method_weight
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.identifiability import IdentifiabilityProblem
from tendon_id.sim import simulate
from tendon_id.zoo.base import NotFittedError
from tendon_id.zoo.inputs import TransmissionInputs
from tendon_id.zoo.registry import make


@pytest.fixture(scope="module")
def data():
    """Terminal-only data with no unmodelled effect (an interior optimum of the smooth law)."""
    return simulate(load_recipe("snake12-noise-only"), "terminal-only", frames=1500, seed=4).recording.fitting_view()


@pytest.fixture
def built(monkeypatch):
    """Every LawProblem built through ``from_model`` while a test runs, in order."""
    seen = []
    original = LawProblem.from_model.__func__

    def spy(cls, *args, **kwargs):
        out = original(cls, *args, **kwargs)
        seen.append(out)
        return out

    monkeypatch.setattr(LawProblem, "from_model", classmethod(spy))
    return seen


def test_the_design_is_the_forward_models_log_drop(data):
    # For a smooth model ln T[1, N] - ln T[N, N] = X theta for ANY law: check X against the model's own
    # propagation through the guides (paper Algorithm 1), not against the formula that built it.
    rng = np.random.default_rng(0)
    for name in ("capstan-simple", "capstan-contact", "capstan-const-mu"):
        for tying in ("tied", "per-guide"):
            model = make(name, tying=tying)
            inputs = TransmissionInputs.from_recordings([data])
            prob = LawProblem.from_model(model, inputs)
            layout = prob.layout
            assert prob.design.shape == (inputs.n_frames, layout.size) and prob.design.flags.c_contiguous
            A = rng.uniform(-0.05, 0.05, size=(layout.n_groups, 3))
            B = np.abs(A) + rng.uniform(0.05, 0.3, size=(layout.n_groups, 3))
            theta = np.stack([layout.join(A[:, i], B[:, i]) for i in range(3)], axis=1)  # (p, 3)
            forward = np.log(inputs.actuator[:, -1]) - np.log(model.terminal_reading(inputs, A, B))
            np.testing.assert_allclose(prob.design @ theta, forward, rtol=1e-10, atol=1e-12)
            np.testing.assert_array_equal(prob.log_drop, np.log(inputs.actuator[:, -1]) - np.log(inputs.terminal))


def test_the_delta_method_weight_is_the_inverse_variance_of_the_log_drop():
    # Closed form: 1 / (1/a^2 + 1/b^2) = a^2 b^2 / (a^2 + b^2); and by Monte Carlo, sigma^2 / w is the
    # variance of ln(a + e1) - ln(b + e2) for small load-cell noise e ~ N(0, sigma^2).
    a, b, sigma = np.array([80.0, 250.0, 400.0]), np.array([60.0, 120.0, 390.0]), 0.5
    w = delta_method_weight(a, b)
    np.testing.assert_allclose(w, a**2 * b**2 / (a**2 + b**2), rtol=1e-14)
    rng = np.random.default_rng(1)
    e = rng.normal(0.0, sigma, size=(2, 400_000, 3))
    var = np.var(np.log(a + e[0]) - np.log(b + e[1]), axis=0)
    np.testing.assert_allclose(var, sigma**2 / w, rtol=0.01)


def test_calibration_posterior_and_identifiability_see_one_problem(data, built):
    model = make("capstan-contact").fit(data)
    # Calibration builds the problem at the blocks' starts, profiles the clearance and the routing wrap
    # on the tied law's, then solves the law on the problem at the fitted geometry: its last.
    cal = built[-1]
    assert cal.values == model.block_params_
    n_cal = len(built)
    post = sample_posterior(model, data, max_steps=1000, chunk=500, target_ess=1.0, encoder_bits=None, seed=0)
    ident = IdentifiabilityProblem.from_model(model, model.inputs(data), "tied")
    posterior_problem, base_of_ident = built[n_cal:]
    assert base_of_ident is ident and isinstance(ident, LawProblem)
    for other in (posterior_problem, ident):
        np.testing.assert_array_equal(other.guide_design, cal.guide_design)
        np.testing.assert_array_equal(other.log_drop, cal.log_drop)
        np.testing.assert_array_equal(other.weight, cal.weight)
        assert other.layout == cal.layout == post.layout == LawLayout("affine-cosine", 1)
    np.testing.assert_array_equal(posterior_problem.design, cal.design)
    # The study ties the guides through its tie matrix (summed in order): equal up to rounding.
    np.testing.assert_allclose(ident.design, cal.design, rtol=1e-13)
    # Calibration fitted exactly that design: the constrained least squares of each tendon (interior optimum).
    for i in range(3):
        x = constrained_lstsq(cal.design[cal.keep], cal.log_drop[cal.keep, i], cal.layout).x
        np.testing.assert_array_equal(cal.layout.join(model.A_[:, i], model.B_[:, i]), x)


def test_the_posteriors_likelihood_is_the_problems_weighted_sum_of_squares(data):
    model = make("capstan-simple", tying="per-guide").fit(data)
    prob = LawProblem.from_model(model, model.inputs(data), values=model.block_params_)
    theta = prob.layout.join(model.A_[:, 1], model.B_[:, 1])
    M, b, c = prob.quadratic(1, sigma=2.0)
    direct = np.sum(prob.weight[:, 1] * (prob.log_drop[:, 1] - prob.design @ theta) ** 2) / 2.0**2
    assert theta @ M @ theta - 2 * b @ theta + c == pytest.approx(direct, rel=1e-9)
    np.testing.assert_allclose(prob.precision(1, 2.0), M, rtol=1e-15)
    # Per guide the tie matrix is the identity: the study's design is the calibration's, bit for bit.
    ident = IdentifiabilityProblem.from_model(model, model.inputs(data))
    np.testing.assert_array_equal(ident.design, prob.design)


def test_calibrate_consumes_a_prebuilt_problem_like_fit(data):
    model = make("capstan-const-mu", tying="per-guide")
    result = calibrate(LawProblem.from_model(model, TransmissionInputs.from_recordings([data])))
    model.fit(data)
    np.testing.assert_array_equal(result.B, model.B_)
    assert result.loss == model.calibration_["loss"]


def test_fitted_parameters_and_inputs_are_public(data):
    model = make("capstan-simple", n_starts=1, maxeval=40).with_blocks("sensor_bias")
    with pytest.raises(NotFittedError):
        model.block_params_
    with pytest.raises(NotFittedError):
        model.inputs(data)
    initial = model.block_params()["sensor_bias"]
    assert model.block_params({"sensor_bias": {"gain": 0.1}})["sensor_bias"] == {**initial, "gain": 0.1}
    model.fit(data)
    assert set(model.block_values_["sensor_bias"]) == {"offset", "gain", "drift"}
    # Every block's parameters are free here, the routing wrap every capstan model fits included.
    assert model.block_params_ == model.block_values_ and set(model.block_values_) == {"sensor_bias", "routing"}
    inputs = model.inputs(data)
    ref = TransmissionInputs.from_recordings([data], model.geometry_)
    np.testing.assert_array_equal(inputs.angles, ref.angles)
    np.testing.assert_array_equal(inputs.terminal, ref.terminal)
    np.testing.assert_allclose(
        model.predict_terminal(data), model.terminal_reading(inputs, model.A_, model.B_, model.block_params_)
    )


def test_the_identifiability_problem_keeps_its_former_name_and_checks_its_model(data):
    assert identifiability.LawProblem is IdentifiabilityProblem
    assert issubclass(IdentifiabilityProblem, problem_module.LawProblem)
    inputs = TransmissionInputs.from_recordings([data])
    with pytest.raises(ConfigError, match="smooth affine-cosine"):
        IdentifiabilityProblem.from_model(make("capstan-const-mu"), inputs, "tied")
    with pytest.raises(ConfigError, match="tying"):
        IdentifiabilityProblem.from_model(make("capstan-simple"), inputs, "sometimes")


def test_ess_and_rhat_of_independent_chains():
    rng = np.random.default_rng(2)
    chain = rng.standard_normal((2000, 8, 2))  # (steps, walkers, params)
    chain[:, :4, 1] += 5.0  # half the walkers elsewhere: not converged
    ess, rhat = ess_rhat(["a", "b"], chain)
    assert 0.8 * 16000 < ess[0] < 1.2 * 16000 and abs(rhat[0] - 1) < 0.01
    assert rhat[1] > 1.5


def test_importing_the_diagnostics_silences_only_arvizs_refactor_notice(tmp_path):
    # ArviZ warns once a day (a stamp in the user cache): a fresh cache makes it warn now.
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "cache")}

    def run(code):
        return subprocess.run(
            [sys.executable, "-W", "error::FutureWarning", "-c", code],
            env=env,
            capture_output=True,
            text=True,
        )

    raw = run("import arviz")
    if raw.returncode == 0:
        pytest.skip("this ArviZ does not warn on import (only recent 0.2x releases do)")
    assert "ArviZ is undergoing a major refactor" in raw.stderr
    (tmp_path / "cache").mkdir(exist_ok=True)
    for stamp in (tmp_path / "cache").rglob("daily_warning"):
        stamp.unlink()  # the failed import may have stamped today
    ours = run("import tendon_id.calibration.mcmc")
    assert ours.returncode == 0, ours.stderr


def test_inputs_of_one_recording_are_its_arrays_without_a_second_copy_nor_an_alias(data):
    """One recording's blocks are taken as they come (issue 42's memory), and never share the frame's memory."""
    inputs = TransmissionInputs.from_recordings(data)
    for name in ("angles", "actuator", "terminal"):
        got = getattr(inputs, name)
        assert not got.flags.owndata, name  # column_block's fresh block itself (a reshaped view), not a copy
        np.testing.assert_array_equal(got, getattr(data, name))
        assert not any(np.shares_memory(got, data.frame[c].to_numpy()) for c in data.frame.columns if c != "trajectory")
    both = TransmissionInputs.from_recordings([data, data])
    np.testing.assert_array_equal(both.actuator, np.concatenate([data.actuator] * 2))
