"""PG-CHTC-NS: its ablations, streaming equals batch, the bounded correction, and the prior guard of both cascades."""

import warnings

import numpy as np
import pytest
import torch

from learners.correction import CorrectionConfig, CorrectionUnit
from tendon_id import zoo
from tendon_id.benchmarks.regimes import nonsmooth_truth_recipe
from tendon_id.data import Recording
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.sim import simulate
from tendon_id.zoo.guard import PriorGuardWarning

TINY = {"preset": "tiny", "device": "cpu", "progress": False}


@pytest.fixture(scope="module")
def data():
    r = load_recipe("snake12-paper")
    train = simulate(r, "posterior-3", frames=800, seed=0).recording
    test = simulate(r, "planned-paths", frames=320, seed=1).recording
    return train, test


@pytest.fixture(scope="module")
def fitted(data):
    return zoo.make("pg-chtc-ns", **TINY).fit(data[0])


@pytest.fixture(scope="module")
def fresh():
    """Truth is capstan-nonsmooth (contact and stick/slip) and every trajectory starts from forward slip."""
    r = nonsmooth_truth_recipe()
    train = Recording.concat(
        [
            simulate(r, "posterior-3", frames=1200, seed=0).recording,
            simulate(r, "planned-paths", frames=945, seed=0).recording,
        ]
    )
    test = simulate(r, "planned-paths", frames=630, seed=1).recording
    return train, test


def test_without_correction_it_is_capstan_nonsmooth(data):
    train, test = data
    plain = zoo.make("capstan-nonsmooth").fit(train)
    ablation = zoo.make("pg-chtc-ns", correction=False).fit(train)
    np.testing.assert_allclose(ablation.predict_chain(test), plain.predict_chain(test), rtol=1e-12)
    assert ablation.cascade_ is None


def test_an_untrained_correction_is_the_prior(fitted, data):
    """The correction's head starts at zero: the cascade is then its prior, whatever the other weights."""
    _, test = data
    for unit in fitted.cascade_.units:
        assert isinstance(unit, CorrectionUnit)
    saved = {k: v.clone() for k, v in fitted.cascade_.state_dict().items()}
    try:
        with torch.no_grad():
            for unit in fitted.cascade_.units:
                unit.head.weight.zero_()
                unit.head.bias.zero_()
        np.testing.assert_allclose(fitted.predict(test), fitted.prior_model_.predict(test), rtol=1e-12)
    finally:
        fitted.cascade_.load_state_dict(saved)


def test_the_correction_is_bounded():
    torch.manual_seed(0)
    unit = CorrectionUnit(CorrectionConfig(hidden=(16,), bound=0.3))
    torch.nn.init.normal_(unit.head.weight, std=50.0)
    with torch.no_grad():
        biggest = float(unit(torch.randn(1000, unit.n_inputs) * 10).abs().max())
    assert 0.29 < biggest <= 0.3 * (1 + 1e-6)  # saturated at the bound (float32), not silently zero


def test_state_inputs_ablation_reads_only_the_paper_inputs(data):
    m = zoo.make("pg-chtc-ns", state_inputs=False, **TINY).fit(data[0])
    assert m.cascade_.units[0].body[0].in_features == 8
    assert zoo.make("pg-chtc-ns", **TINY).fit(data[0]).cascade_.units[0].body[0].in_features == 8 + 12


@pytest.mark.parametrize("correction", [True, False])
def test_streaming_equals_batch(fitted, data, correction):
    train, test = data
    model = fitted if correction else zoo.make("pg-chtc-ns", correction=False).fit(train)
    stream = model.streamer()
    for traj in test.trajectories[:2]:  # the second starts after a reset
        one = test.select([traj])
        stream.reset()
        out = np.stack([stream.step(one.angles[t], one.actuator[t]) for t in range(one.n_frames)])
        assert np.max(np.abs(out / model.predict(one) - 1.0)) <= 1e-5


def test_saved_model_predicts_the_same_and_keeps_its_guard(fitted, data, tmp_path):
    _, test = data
    fitted.save(tmp_path / "m")
    back = zoo.load(tmp_path / "m")
    np.testing.assert_array_equal(back.predict(test), fitted.predict(test))
    assert back.guard_ == fitted.guard_
    np.testing.assert_array_equal(back.prior_model_.A_, fitted.prior_model_.A_)


def test_on_nonsmooth_truth_with_a_fresh_start_it_is_within_1_1_of_capstan_nonsmooth(fresh):
    train, test = fresh
    plain = zoo.make("capstan-nonsmooth").fit(train).score(test)["terminal"]["rmse"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PriorGuardWarning)
        ns = zoo.make("pg-chtc-ns", **TINY).fit(train).score(test)["terminal"]["rmse"]
    assert ns <= 1.1 * plain, (ns, plain)


def test_the_guard_fires_for_pg_chtc_on_nonsmooth_truth_and_the_fallback_predicts_with_the_prior(fresh):
    train, test = fresh
    with pytest.warns(PriorGuardWarning, match="worse than its prior capstan-nonsmooth"):
        paper = zoo.make("pg-chtc", **TINY).fit(train)
    g = paper.guard_
    assert g["worse"] and g["cascade_rmse"] > g["prior_rmse"] > 0 and not g["fallback"]
    assert g["ratio"] == pytest.approx(g["cascade_rmse"] / g["prior_rmse"])
    assert not paper.uses_prior_
    with pytest.warns(PriorGuardWarning, match="it predicts with capstan-nonsmooth"):
        safe = zoo.make("pg-chtc", fallback=True, **TINY).fit(train)
    assert safe.uses_prior_
    with pytest.raises(ConfigError, match="stream pg-chtc-ns instead"):
        safe.streamer()
    np.testing.assert_array_equal(safe.predict(test), safe.prior_model_.predict(test))
    np.testing.assert_array_equal(safe.predict_terminal(test), safe.prior_model_.predict_terminal(test))
    # the prior is capstan-nonsmooth calibrated on the training trajectories, and so scores like it
    assert safe.score(test)["terminal"]["rmse"] < paper.score(test)["terminal"]["rmse"]
