"""The prior guard judges each kind of motion on its own: the warning names it, and fallback="per-kind" uses the
prior on that kind's trajectories only.

A stand-in cascade makes the case exact: its terminal error is its prior's times a factor set per protocol
(read from the simulator's trajectory ids, which the guard never sees), so the guard must find the kind from the
joint angles to get it right.
"""

import warnings

import numpy as np
import pytest

from tendon_id import zoo
from tendon_id.data import Recording
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.sim import simulate
from tendon_id.zoo.guard import GuardedCascade, PriorGuardWarning, guard_message, guard_report
from tendon_id.zoo.inputs import as_recordings
from tendon_id.zoo.registry import register, unregister


class StandIn(GuardedCascade):
    """The prior's chain, with the terminal error scaled by ``steps`` on step trajectories and ``paths`` on paths."""

    name = "guard-stand-in"

    def __init__(self, steps: float = 0.0, paths: float = 1.1, fallback=False):
        self.steps, self.paths, self.fallback = steps, paths, fallback

    def fit(self, data):
        self.check_settings()
        allrec = Recording.concat([r.fitting_view() for r in as_recordings(data)])
        ids = allrec.trajectories
        val = allrec.select(ids[1::2])  # every other trajectory: both protocols are in validation
        self.prior_model_ = zoo.make("capstan-contact").fit(allrec.select(ids[0::2]))
        self.n_modules_ = allrec.n_modules
        self._guard(val)
        return self

    def predict_chain(self, data):
        recs = self._check_data(data)
        prior = self._prior_chain(recs)
        if prior is not None:
            return prior
        chain = self.prior_model_.predict_chain(recs)
        ids = np.concatenate([r.trajectory_ids for r in recs])
        label = np.concatenate([r.terminal for r in recs])
        factor = np.where(np.char.startswith(ids.astype(str), "posterior"), self.steps, self.paths)[:, None]
        n = self.n_modules_
        chain[:, n - 1, n - 1] = label + factor * (chain[:, n - 1, n - 1] - label)
        return self._prior_where_worse(recs, chain)

    def _state(self):
        state, arrays = self._prior_state()
        return {"n_modules": self.n_modules_, **state}, arrays

    def _restore(self, state, arrays):
        self.n_modules_ = int(state["n_modules"])
        self._restore_prior(state, arrays)


@pytest.fixture(scope="module", autouse=True)
def stand_in():
    register(StandIn)
    yield
    unregister(StandIn.name)


@pytest.fixture(scope="module")
def data():
    r = load_recipe("snake12-paper")
    train = [
        simulate(r, "posterior-3", frames=1200, seed=0).recording,
        simulate(r, "planned-paths", frames=945).recording,
    ]
    test = Recording.concat(
        [
            simulate(r, "posterior-3", frames=400, seed=1).recording,
            simulate(r, "planned-paths", frames=630, seed=1).recording,
        ]
    )
    return train, test


def fit(data, **params):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PriorGuardWarning)
        model = zoo.make("guard-stand-in", **params).fit(data[0])
    return model, [str(w.message) for w in caught if issubclass(w.category, PriorGuardWarning)]


def paths_rows(test):
    return np.char.startswith(test.trajectory_ids.astype(str), "planned-paths")


def test_better_on_the_pool_but_worse_on_paths_warns_and_names_paths(data):
    model, caught = fit(data)
    g = model.guard_
    assert not g["worse"] and g["ratio"] < 1.0  # the pool hides it
    assert set(g["kinds"]) == {"steps", "paths"}
    assert g["kinds"]["paths"]["worse"] and g["kinds"]["paths"]["ratio"] == pytest.approx(1.1)
    assert not g["kinds"]["steps"]["worse"] and g["kinds"]["steps"]["ratio"] == pytest.approx(0.0)
    assert sum(k["frames"] for k in g["kinds"].values()) == g["frames"]
    assert all(k["trajectories"] >= 1 for k in g["kinds"].values())
    assert not g["fallback"] and g["fallback_kinds"] == [] and model.prior_kinds_ == ()
    assert len(caught) == 1 and "capstan-contact on some kinds of motion (paths 1.10x)" in caught[0]
    assert "steps" not in caught[0].split("\n")[1] and "--set fallback=per-kind" in caught[0]
    _, test = data  # without a fallback the cascade predicts everywhere, paths included
    rows = paths_rows(test)
    assert not np.allclose(model.predict_terminal(test)[rows], model.prior_model_.predict_terminal(test)[rows])


def test_per_kind_fallback_predicts_only_that_kinds_trajectories_with_the_prior(data, tmp_path):
    model, caught = fit(data, fallback="per-kind")
    _, test = data
    assert model.guard_["fallback_kinds"] == ["paths"] and model.prior_kinds_ == ("paths",)
    assert not model.uses_prior_ and not model.guard_["fallback"]
    assert len(caught) == 1 and "it predicts paths trajectories with capstan-contact" in caught[0]
    rows = paths_rows(test)
    assert rows.any() and (~rows).any()
    prior, cascade = model.prior_model_, StandIn(steps=0.0, paths=1.1)
    cascade.prior_model_, cascade.n_modules_, cascade.guard_ = prior, model.n_modules_, {}
    for method in ("predict_chain", "predict", "predict_terminal"):
        got, want_prior, want_cascade = (getattr(m, method)(test) for m in (model, prior, cascade))
        np.testing.assert_array_equal(got[rows], want_prior[rows])
        np.testing.assert_array_equal(got[~rows], want_cascade[~rows])
        assert not np.allclose(want_cascade[~rows], want_prior[~rows], equal_nan=True)
    # and it scores better on held-out paths than the cascade, as well as the prior on them
    assert model.score(test)["terminal"]["rmse"] < cascade.score(test)["terminal"]["rmse"]
    # the per-kind decision, and the rules the kinds are read with, survive save and load (JSON + npz)
    model.save(tmp_path / "m")
    back = zoo.load(tmp_path / "m")
    assert back.guard_ == model.guard_ and back.prior_kinds_ == ("paths",) and back.kind_rules_ == model.kind_rules_
    np.testing.assert_array_equal(back.predict_chain(test), model.predict_chain(test))
    with pytest.warns(PriorGuardWarning, match="streams its cascade on every kind of motion"):
        back._warn_stream_kinds()


def test_fallback_true_keeps_its_meaning_the_pool_decides(data):
    model, caught = fit(data, fallback=True)
    _, test = data
    assert not model.uses_prior_ and model.prior_kinds_ == ()  # the pool passed: the cascade everywhere
    assert len(caught) == 1 and "(paths 1.10x)" in caught[0]
    assert not np.allclose(model.predict(test)[paths_rows(test)], model.prior_model_.predict(test)[paths_rows(test)])


@pytest.mark.parametrize("fallback", [True, "per-kind"])
def test_a_pool_that_fails_sends_everything_to_the_prior(data, fallback):
    model, caught = fit(data, steps=1.5, paths=1.2, fallback=fallback)
    g = model.guard_
    assert g["worse"] and g["fallback"] and g["fallback_kinds"] == [] and model.uses_prior_
    assert all(k["worse"] for k in g["kinds"].values())
    assert "it predicts with capstan-contact" in caught[0]
    _, test = data
    np.testing.assert_array_equal(model.predict(test), model.prior_model_.predict(test))


def test_a_pool_that_fails_without_fallback_names_the_worse_kinds(data):
    _, caught = fit(data, steps=1.5, paths=0.5)
    assert "on held-out trajectories (steps 1.50x); use capstan-contact instead" in caught[0]


def test_an_unknown_fallback_is_refused_before_training(data):
    with pytest.raises(ConfigError, match="unknown fallback 'kind'"):
        zoo.make("guard-stand-in", fallback="kind").fit(data[0])
    with pytest.raises(ConfigError, match="unknown fallback"):
        zoo.make("pg-chtc-ns", fallback="sometimes").fit(data[0])


def test_a_guard_stored_before_the_breakdown_reads_as_before():
    old = guard_report(2.0, 1.0, "capstan-nonsmooth", 100, False)
    del old["kinds"], old["fallback_kinds"]
    text = guard_message("pg-chtc", old)
    assert text.splitlines()[0].endswith("(2.00x, 100 frames)")
    assert "refit with fallback=True" in text
    assert guard_message("pg-chtc", {**old, "worse": False, "ratio": 0.5}).count("\n") == 0
