"""Every model of the zoo keeps one contract (tendon_id.zoo.testing.check_model), and the zoo loads lazily."""

import subprocess
import sys

import numpy as np
import pytest

from tendon_id import zoo
from tendon_id.datasets import load_recipe
from tendon_id.sim import simulate
from tendon_id.zoo import testing

#: Fast settings per model: one calibration start for the analytic ones, the tiny preset on the CPU for the neural ones.
FAST = {
    "proximal": {},
    "capstan": {"n_starts": 1, "maxeval": 60},
    "neural": {"preset": "tiny", "device": "cpu", "progress": False},
}


def fast_settings(name: str) -> dict:
    cls = zoo.model_class(name)
    if name == "proximal":
        return {}
    if issubclass(cls, zoo.CapstanModel):
        return FAST["capstan"]
    return {k: v for k, v in FAST["neural"].items() if k in cls.param_names()}


@pytest.fixture(scope="module")
def data():
    r = load_recipe("snake12-paper")
    train = simulate(r, "posterior-3", frames=600, seed=0).recording  # three trajectories
    test = simulate(r, "planned-paths", frames=200, seed=1).recording
    return train, test


@pytest.mark.parametrize("name", [n for n in zoo.names() if not n.startswith("passage-")])  # passages: test_passage
def test_every_registered_model_keeps_the_contract(data, name):
    testing.check_model(zoo.make(name, **fast_settings(name)), *data)


@pytest.mark.parametrize("blocks", [["contact"], ["contact", "viscoelastic"], ["hysteresis", "sensor_bias"]])
def test_capstan_with_blocks_keeps_the_contract(data, blocks):
    testing.check_model(zoo.make("capstan", blocks=blocks, **FAST["capstan"]), *data)


class _PeeksAtTruth(zoo.ProximalModel):
    """Breaks the contract on purpose: scales its estimate by the training data's intermediate truth."""

    name = "peeks-at-truth"

    def fit(self, data):
        super().fit(data)
        truth = data.joint_truth
        self.scale_ = 1.0 if truth is None else float(np.mean(truth[:, 0]))
        return self

    def predict_chain(self, data):
        return super().predict_chain(data) * self.scale_

    def _state(self):
        state, arrays = super()._state()
        return {**state, "scale": self.scale_}, arrays

    def _restore(self, state, arrays):
        super()._restore(state, arrays)
        self.scale_ = state["scale"]


class _CountsPredictions(zoo.ProximalModel):
    """Breaks the contract on purpose: ``predict`` changes its fitted state."""

    name = "counts-predictions"

    def predict_chain(self, data):
        self.calls_ = getattr(self, "calls_", 0) + 1
        return super().predict_chain(data)

    def _state(self):
        state, arrays = super()._state()
        return {**state, "calls": getattr(self, "calls_", 0)}, arrays


def test_the_check_catches_a_model_whose_predict_has_side_effects(data):
    with pytest.raises(AssertionError, match="predict changed the model's fitted state"):
        testing.check_model(_CountsPredictions(), *data)


def test_the_check_catches_a_model_that_reads_intermediate_truth(data):
    with pytest.raises(AssertionError, match="intermediate joint-side truth"):
        testing.check_model(_PeeksAtTruth(), *data)


def test_importing_the_zoo_and_fitting_a_capstan_model_do_not_import_torch():
    code = (
        "import sys, tendon_id.zoo as zoo\n"
        "from tendon_id.datasets import load_recipe\nfrom tendon_id.sim import simulate\n"
        "rec = simulate(load_recipe('snake12-paper'), 'posterior-3', frames=300, seed=0).recording\n"
        "zoo.make('capstan-nonsmooth', n_starts=1, maxeval=40).fit(rec).predict(rec)\n"
        "assert 'torch' not in sys.modules, 'torch was imported'\n"
        "zoo.make('pg-chtc')\nassert 'torch' in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_names_of_a_family_does_not_depend_on_what_is_loaded():
    before = zoo.names_of(zoo.CapstanModel)
    for name in zoo.names():
        zoo.model_class(name)  # load every module
    assert zoo.names_of(zoo.CapstanModel) == before
    assert before == ["capstan-simple", "capstan-contact", "capstan-nonsmooth", "capstan-const-mu", "capstan"]
    assert zoo.names_of(zoo.ProximalModel) == ["proximal"]
