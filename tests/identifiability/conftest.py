"""Studies shared by the identifiability tests (computed once per session: each takes seconds)."""

import pytest

from tendon_id.datasets import load_recipe
from tendon_id.identifiability import StudySettings, analyse
from tendon_id.sim import simulate

#: Small sampler settings: enough for the structure, the bands and the advice's check.
SMALL = StudySettings(n_chains=32, n_steps=300, thin=10, band_frames=400, emcee=True, check_advice=True)
#: Smaller still, for the misspecified recipe, whose check only has to run.
QUICK = StudySettings(n_chains=16, n_steps=60, thin=5, band_frames=200, emcee=False, check_advice=True)


@pytest.fixture(scope="session")
def noise_only():
    """Terminal-only data with no unmodelled effect: the capstan law is the truth."""
    return simulate(load_recipe("snake12-noise-only"), "terminal-only", frames=6000, seed=3).recording


@pytest.fixture(scope="session")
def study(noise_only):
    return analyse(noise_only, SMALL)


@pytest.fixture(scope="session")
def paper_terminal_only():
    """Terminal-only data of the paper recipe: stick–slip, lag and contact the smooth capstan lacks."""
    return simulate(load_recipe("snake12-paper"), "terminal-only", frames=3000, seed=1).recording


@pytest.fixture(scope="session")
def misspecified(paper_terminal_only):
    return analyse(paper_terminal_only, QUICK, progress=False)
