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
