"""The estimator in closed loop: a 10 Hz hybrid controller on a simulated robot (paper Section IV-C).

See :doc:`/guide/closed_loop`.

* :mod:`~tendon_id.closed_loop.plant`: joint dynamics driven through the truth transmission.
* :mod:`~tendon_id.closed_loop.statics`: every tendon's moment on every joint it crosses, gravity, inertia.
* :mod:`~tendon_id.closed_loop.controller`: the hybrid tension and configuration controller.
* :mod:`~tendon_id.closed_loop.distribution`: a desired joint moment as tensions of any number of tendons.
* :mod:`~tendon_id.closed_loop.estimators`: the oracle and fitted zoo models, frame by frame.
* :mod:`~tendon_id.closed_loop.run`: the step-and-return tests and their Table III metrics.
* :mod:`~tendon_id.closed_loop.metrics`: rise and settling times (python-control) and RMS error.
"""

from tendon_id.closed_loop.controller import HybridController, HybridGains
from tendon_id.closed_loop.distribution import TensionDistribution, tension_distribution
from tendon_id.closed_loop.estimators import ORACLE, InLoopEstimator, ModelInLoop, OracleInLoop, in_loop
from tendon_id.closed_loop.metrics import StepMetrics, rms_error, step_metrics
from tendon_id.closed_loop.plant import JointDynamics, Plant, joint_torque
from tendon_id.closed_loop.run import STEP_TESTS, ClosedLoopRun, StepTest, loop_metrics, run_step_test, step_test

__all__ = [
    "ORACLE",
    "STEP_TESTS",
    "ClosedLoopRun",
    "HybridController",
    "HybridGains",
    "InLoopEstimator",
    "JointDynamics",
    "ModelInLoop",
    "OracleInLoop",
    "Plant",
    "StepMetrics",
    "StepTest",
    "TensionDistribution",
    "in_loop",
    "joint_torque",
    "loop_metrics",
    "rms_error",
    "run_step_test",
    "step_metrics",
    "step_test",
    "tension_distribution",
]
