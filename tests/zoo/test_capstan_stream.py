"""The capstan models stream frame by frame: the same estimates as batch prediction, O(1) state, clear refusals."""

import numpy as np
import pytest

from tendon_id import zoo
from tendon_id.closed_loop.estimators import ModelInLoop
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.sim import simulate
from tendon_id.zoo.inputs import TransmissionInputs


@pytest.fixture(scope="module")
def data():
    r = load_recipe("snake12-paper")
    train = simulate(r, "posterior-3", frames=300, seed=0).recording
    test = simulate(r, "posterior-3", frames=300, seed=1).recording
    assert len(test.trajectories) >= 2  # the stream is reset between them
    return train, test


def stream(model, rec):
    """Every frame of ``rec`` through ``model.streamer()``, reset at each trajectory's first frame."""
    st = model.streamer()
    reset = TransmissionInputs.from_recordings(rec, model.geometry_).reset
    out = []
    for t in range(rec.n_frames):
        if reset[t]:
            st.reset()
        out.append(st.step(rec.angles[t], rec.actuator[t]))
    return np.stack(out)


@pytest.mark.parametrize(
    "name, settings",
    [
        ("capstan-nonsmooth", {}),
        ("capstan-nonsmooth", {"tying": "per-guide"}),
        ("capstan-simple", {}),
        ("capstan-contact", {}),
        ("capstan-const-mu", {}),
        ("capstan", {"blocks": [{"block": "contact", "gate": "hard"}, "hysteresis"]}),
    ],
)
def test_streaming_equals_batch_prediction(data, name, settings):
    train, test = data
    model = zoo.make(name, n_starts=1, maxeval=60, **settings).fit(train)
    out = stream(model, test)
    batch = model.predict(test)
    np.testing.assert_allclose(out, batch, rtol=1e-12, atol=0)  # measured: the same bits
    np.testing.assert_array_equal(out[:, 0], test.actuator[:, 0])  # set 1 is its reading


def test_the_stream_carries_the_stick_state(data):
    """Hysteresis: a stream that forgets its play state (reset every frame) is forward slip, and differs."""
    train, test = data
    model = zoo.make("capstan-nonsmooth", n_starts=1, maxeval=60).fit(train)
    st = model.streamer()
    forgetful = []
    for t in range(test.n_frames):
        st.reset()
        forgetful.append(st.step(test.angles[t], test.actuator[t]))
    assert np.max(np.abs(np.stack(forgetful) / stream(model, test) - 1.0)) > 1e-3


def test_a_block_that_keeps_state_over_time_does_not_stream(data):
    train, _ = data
    geometry = zoo.make("capstan-simple").fit(train).geometry_
    model = zoo.make("capstan", blocks=["velocity_friction"]).fitted_with(np.zeros(3), np.full(3, 0.2), geometry, 12)
    with pytest.raises(ConfigError, match="velocity_friction"):
        model.streamer()
    # In the closed loop such a model takes the history route instead of failing.
    est = ModelInLoop(model, "velocity", dt=0.1)
    est.reset(needs_chain=False)
    assert est.stream is None and est.streamer is None
