"""The start-state observer: each log's first stick state from its first terminal reading."""

import dataclasses

import numpy as np
import pytest

from tendon_id import zoo
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.sim import Sensors, simulate
from tendon_id.zoo import StartState
from tendon_id.zoo.inputs import TransmissionInputs

# The feasible law of snake12-noise-only, noise-free: logs cut from one continuous session.
RECIPE = dataclasses.replace(
    load_recipe("snake12-noise-only"), session="continuous", sensors=Sensors(noise_n=0.0, encoder_bits=24)
)


def test_the_observer_starts_each_log_on_its_first_reading_and_lowers_the_error():
    rec = simulate(RECIPE, "posterior-6", effects="contact,stick_slip", frames=1200, seed=4).recording
    inputs = TransmissionInputs.from_recordings(rec)
    law = (np.array([RECIPE.friction.A]), np.array([RECIPE.friction.B]))
    geometry = {"contact": {"alpha_c": RECIPE.robot.alpha_c}, "routing": {"alpha_0": RECIPE.robot.alpha_0}}
    base = zoo.make("capstan-nonsmooth")
    observed = base.with_blocks(StartState())
    taut = base.terminal_reading(inputs, *law, geometry)
    start = observed.terminal_reading(inputs, *law, geometry)
    first = inputs.reset
    # at each log's first frame the observer reads the terminal cell (inside the dead zone)
    np.testing.assert_allclose(start[first], rec.terminal[first], rtol=1e-6)  # 24-bit angles: 3e-8 measured
    # and with the true law the inherited state explains the taut start's error
    err_taut = np.sqrt(np.mean((taut - rec.terminal) ** 2))
    err_start = np.sqrt(np.mean((start - rec.terminal) ** 2))
    assert err_start < 0.5 * err_taut, (err_start, err_taut)
    # on a fresh session's logs (taut at every start) it changes next to nothing
    fresh = simulate(dataclasses.replace(RECIPE, session="fresh"), "posterior-6", effects="contact,stick_slip",
                     frames=600, seed=4).recording  # fmt: skip
    fin = TransmissionInputs.from_recordings(fresh)
    gap = observed.terminal_reading(fin, *law, geometry) - base.terminal_reading(fin, *law, geometry)
    assert np.max(np.abs(gap)) < 1e-4  # 5e-6 N measured: the first reading is a hair off the taut edge


def test_it_needs_a_step_with_a_pass_over_the_whole_chain():
    with pytest.raises(ConfigError, match="start_state"):
        zoo.make("capstan-nonsmooth").with_blocks("smooth_edge", StartState()).block_objects
    with pytest.raises(ConfigError, match="every guide of a tendon at once"):
        zoo.make("capstan-nonsmooth").with_blocks(StartState(), "viscoelastic").block_objects
    assert zoo.make("capstan-nonsmooth").with_blocks(StartState(), "elastic_tendon").block_objects
