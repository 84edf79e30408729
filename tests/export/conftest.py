"""What the export tests share: a small simulated recording, its frames, and a C compiler (or a skip)."""

import pytest

from tendon_id.datasets import load_recipe
from tendon_id.export.run import find_compiler
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
