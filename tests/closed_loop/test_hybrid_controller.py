"""The hybrid controller's rate term and chain low-pass (issue 40), by hand."""

import numpy as np
import pytest

from tendon_id.closed_loop import HybridController, HybridGains, JointDynamics, Plant
from tendon_id.closed_loop.statics import on_path
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError

PERIOD = 0.1


@pytest.fixture(scope="module")
def robot():
    """The full statics with no elastic return, so the hold torque is the feedback terms alone."""
    return Plant(load_recipe("snake12-paper"), batch=1, dynamics=JointDynamics(statics="full", stiffness=0.0))


def _controller(robot, **gains):
    return HybridController(HybridGains(**gains), robot.psi, robot.geometry.hole_radius, robot, PERIOD, 400.0)


def _chain(level: float) -> np.ndarray:
    return np.where(on_path(12)[:, :, None], level, 0.0) * np.ones((12, 12, 3))


def test_the_rate_term_is_kd_times_the_error_difference_over_the_period(robot):
    """kd (e2 - e1) / T on the second period equals kp e with kp = kd / T and e = e2 - e1."""
    e1, e2 = np.full((12, 2), 0.01), np.full((12, 2), 0.03)
    angles, actuator, chain = np.zeros((12, 2)), np.full((12, 3), 80.0), _chain(80.0)
    rate = _controller(robot, kp=0.0, ki=0.0, kd=0.5)
    prop = _controller(robot, kp=0.5 / PERIOD, ki=0.0)
    rate.command(e1, angles, actuator, chain)
    prop.command(np.zeros((12, 2)), angles, actuator, chain)
    rate.command(e2, angles, actuator, chain)
    prop.command(e2 - e1, angles, actuator, chain)
    np.testing.assert_allclose(rate.last_desired, prop.last_desired, rtol=1e-12)
    assert np.ptp(rate.last_desired) > 1.0  # the term does move the desired tensions


def test_the_chain_low_pass_is_first_order(robot):
    ctrl = _controller(robot, chain_smoothing=0.3)
    angles, actuator = np.zeros((12, 2)), np.full((12, 3), 80.0)
    ctrl.command(np.zeros((12, 2)), angles, actuator, _chain(80.0))
    ctrl.command(np.zeros((12, 2)), angles, actuator, _chain(100.0))
    np.testing.assert_allclose(ctrl.chain, _chain(86.0), rtol=1e-12)  # 80 + 0.3 (100 - 80)


def test_bad_gains_are_refused():
    with pytest.raises(ConfigError, match="kd"):
        HybridGains(kd=-1.0)
    with pytest.raises(ConfigError, match="chain_smoothing"):
        HybridGains(chain_smoothing=0.0)


class _WindowedModel:
    """A stand-in for a model with a 5-frame history window: it checks the window and echoes the actuator side."""

    history_frames = 5

    def check_fitted(self):
        return None

    def predict_chain(self, rec):
        assert rec.n_frames >= self.history_frames  # what a windowed zoo model's check refuses
        self.seen = rec.actuator.copy()
        n = rec.actuator.shape[1]
        return np.broadcast_to(rec.actuator[:, None], (rec.n_frames, n, n, 3)).copy()


def test_a_windowed_model_sees_the_first_frame_repeated_before_the_run():
    from tendon_id.closed_loop import ModelInLoop

    model = _WindowedModel()
    est = ModelInLoop(model, "windowed", PERIOD)
    first, second = np.full((12, 3), 80.0), np.full((12, 3), 90.0)
    out = est.step(np.zeros((12, 2)), first, None)
    assert model.seen.shape[0] == 5 and np.all(model.seen == 80.0)
    np.testing.assert_array_equal(out[3, 7], first[7])
    out = est.step(np.zeros((12, 2)), second, None)
    assert model.seen.shape[0] == 6 and np.all(model.seen[-1] == 90.0) and np.all(model.seen[:-1] == 80.0)
    np.testing.assert_array_equal(out[3, 7], second[7])
