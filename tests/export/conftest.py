"""What the export tests share: a small simulated recording, and stepping a recording through any streamer."""

import numpy as np
import pytest

from tendon_id.datasets import load_recipe
from tendon_id.export.run import CStep, find_compiler
from tendon_id.sim import simulate
from tendon_id.zoo.inputs import TransmissionInputs


@pytest.fixture(scope="session")
def recordings():
    """(train, test): posterior-3 of the paper robot, 300 frames each; the test one has two trajectories."""
    r = load_recipe("snake12-paper")
    train = simulate(r, "posterior-3", frames=300, seed=0).recording
    test = simulate(r, "posterior-3", frames=300, seed=1).recording
    assert len(test.trajectories) >= 2
    return train, test


def stream_recording(stepper, angles, actuator, reset) -> np.ndarray:
    """Every frame through ``stepper`` (``step(angles, actuator)``, ``reset()``), reset where ``reset`` is True."""
    out = []
    for t in range(len(angles)):
        if reset[t]:
            stepper.reset()
        out.append(stepper.step(angles[t], actuator[t]))
    return np.stack(out)


#: The C export compiles as pedantic C99 without a warning.
STRICT = ("-O2", "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror")


def strict_c(folder) -> CStep:
    """The exported C step of ``folder``, compiled with :data:`STRICT`."""
    return CStep(folder, flags=STRICT)


@pytest.fixture(scope="session")
def frames(recordings):
    """The test recording's (angles, actuator, reset)."""
    _, test = recordings
    return test.angles, test.actuator, TransmissionInputs.from_recordings(test).reset


@pytest.fixture
def compiler():
    cc = find_compiler()
    if cc is None:
        pytest.skip("no C compiler here (set CC, or install gcc or clang): the C export is not compiled")
    return cc
