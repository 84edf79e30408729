"""Fitting at scale (issue 42): the leaner arrays give the bits of what they replace."""

from __future__ import annotations

import numpy as np
import pytest

from tendon_id.calibration.problem import guide_design
from tendon_id.datasets import load_recipe
from tendon_id.sim import simulate
from tendon_id.zoo.chain import log_entering
from tendon_id.zoo.inputs import TransmissionInputs
from tendon_id.zoo.registry import make


@pytest.fixture(scope="module")
def inputs():
    rec = simulate(load_recipe("snake12-paper"), "terminal-only", frames=600, seed=3).recording.fitting_view()
    return TransmissionInputs.from_recordings(rec)


def bits(a):
    return np.ascontiguousarray(a).view(np.int64)


@pytest.mark.parametrize("name", ["capstan-simple", "capstan-contact", "capstan-nonsmooth"])
def test_guide_design_has_the_bits_of_the_stacked_formula(inputs, name):
    model = make(name)
    values = {**model.block_params(), "routing": {"alpha_0": 0.21}}  # a routing wrap that clips some frames at pi
    m = model.exponent_multiplier(inputs, values)[..., 0]
    wrap = model.backbone(inputs, values)
    before = np.stack([m * wrap * np.cos(wrap), m * wrap], axis=-1)
    got = guide_design(model, inputs, values)
    assert got.shape == before.shape and got.flags.c_contiguous
    assert np.array_equal(bits(got), bits(before))


def test_log_entering_takes_the_log_of_only_what_it_returns(inputs):
    model = make("capstan-nonsmooth")
    full = np.log(inputs.actuator)
    for sets in ([11], [0, 4, 11], list(range(12))):
        for tendons in ([0], [2], [0, 1, 2]):
            s, t = np.array(sets), np.array(tendons)
            got = log_entering(model.block_objects, inputs, {}, s, t)
            assert np.array_equal(bits(got), bits(full[:, s][:, :, t]))
    assert "log_actuator" not in vars(inputs)  # the whole (T, N, n) logarithm is never made
