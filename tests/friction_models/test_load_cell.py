"""The load cell's signal operations and the run-in/wear law (docs/guide/simulator.rst, "Sensors as they are built")."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from friction_models import first_order_lowpass, gain_offset, run_in_wear_factor, shifted_read

RNG = np.random.default_rng(0)


def test_gain_and_offset_are_applied_exactly_and_broadcast():
    T = RNG.uniform(50.0, 300.0, size=(40, 12, 3))
    g = RNG.normal(0.0, 0.02, size=(12, 3))
    o = RNG.normal(0.0, 2.0, size=(12, 3))
    np.testing.assert_array_equal(gain_offset(T, g, o), (1.0 + g) * T + o)
    np.testing.assert_array_equal(gain_offset(T, 0.0, 0.0), T)
    with pytest.raises(ValueError, match="gain"):
        gain_offset(T, -1.0, 0.0)


def test_a_whole_frame_shift_is_the_samples_shifted_within_each_segment():
    x = RNG.normal(size=(30, 4, 3))
    reset = np.zeros(30, dtype=bool)
    reset[[12, 20]] = True
    ends = [11, 19, 29]
    later = shifted_read(x, 1.0, reset)
    earlier = shifted_read(x, -1.0, reset)
    for lo, hi in zip([0, 12, 20], ends):
        np.testing.assert_array_equal(later[lo:hi], x[lo + 1 : hi + 1])
        np.testing.assert_array_equal(later[hi], x[hi])  # held at the segment's last frame
        np.testing.assert_array_equal(earlier[lo + 1 : hi + 1], x[lo:hi])
        np.testing.assert_array_equal(earlier[lo], x[lo])  # and at its first
    np.testing.assert_array_equal(shifted_read(x, 0.0, reset), x)
    np.testing.assert_array_equal(shifted_read(x, 3.0)[:27], x[3:])  # no reset: one segment


@settings(max_examples=50, deadline=None)
@given(shift=st.floats(-4.0, 4.0, allow_nan=False), slope=st.floats(-50.0, 50.0), level=st.floats(-100.0, 100.0))
def test_a_fractional_shift_of_a_ramp_is_the_ramp_shifted(shift, slope, level):
    t = np.arange(40.0)
    x = level + slope * t[:, None] * np.array([1.0, -0.5, 2.0])  # (T, 3): vectorised over the trailing axis
    got = shifted_read(x, shift)
    want = level + slope * np.clip(t + shift, 0, 39)[:, None] * np.array([1.0, -0.5, 2.0])
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)


def test_the_low_pass_step_response_reaches_1_minus_1_over_e_after_tau():
    dt, tau = 0.01, 0.1
    x = np.ones(60)
    x[0] = 0.0
    y = first_order_lowpass(x, dt, tau)
    k = np.arange(60)
    np.testing.assert_allclose(y, 1.0 - np.exp(-k * dt / tau), rtol=1e-12, atol=1e-15)
    assert y[10] == pytest.approx(1.0 - np.exp(-1.0), rel=1e-12)  # tau = 10 frames


def test_the_low_pass_restarts_settled_at_each_reset_and_keeps_a_constant():
    x = RNG.normal(size=(50, 2, 3))
    reset = np.zeros(50, dtype=bool)
    reset[25] = True
    y = first_order_lowpass(x, 0.1, 0.3, reset)
    np.testing.assert_array_equal(y[[0, 25]], x[[0, 25]])
    np.testing.assert_array_equal(y[25:], first_order_lowpass(x[25:], 0.1, 0.3))  # the second segment on its own
    a = np.exp(-0.1 / 0.3)
    np.testing.assert_allclose(y[1:25], a * y[:24] + (1 - a) * x[1:25], rtol=1e-12, atol=1e-14)
    for j in range(2):  # vectorised over the trailing axes: each column on its own
        np.testing.assert_allclose(y[:, j, 1], first_order_lowpass(x[:, j, 1], 0.1, 0.3, reset), rtol=1e-14)
    np.testing.assert_allclose(first_order_lowpass(np.full((20, 3), 7.5), 0.1, 0.3), 7.5, rtol=1e-14)
    with pytest.raises(ValueError, match="positive"):
        first_order_lowpass(x, 0.1, 0.0)


def test_run_in_wear_factor_starts_at_one_and_is_monotone_in_its_parameters():
    s = np.linspace(0.0, 5.0, 101)
    w = run_in_wear_factor(s, 0.2, 0.5, 0.05)
    assert w[0] == 1.0
    np.testing.assert_allclose(w, 1 - 0.2 * (1 - np.exp(-s / 0.5)) + 0.05 * s, rtol=1e-14)
    assert np.all(w > 1 - 0.2)
    pos = s[1:]
    assert np.all(run_in_wear_factor(pos, 0.3, 0.5, 0.05) < run_in_wear_factor(pos, 0.2, 0.5, 0.05))  # drop
    assert np.all(run_in_wear_factor(pos, 0.2, 1.0, 0.05) > run_in_wear_factor(pos, 0.2, 0.5, 0.05))  # length
    assert np.all(run_in_wear_factor(pos, 0.2, 0.5, 0.10) > run_in_wear_factor(pos, 0.2, 0.5, 0.05))  # wear
    assert np.all(np.diff(run_in_wear_factor(s, 0.2, 0.5, 0.0)) < 0)  # run-in alone only falls
    assert np.all(np.diff(run_in_wear_factor(s, 0.0, 0.5, 0.05)) > 0)  # wear alone only rises
    np.testing.assert_array_equal(run_in_wear_factor(s, 0.0, 0.5, 0.0), 1.0)


@pytest.mark.parametrize(
    "args, match",
    [((1.0, 0.5, 0.0), "run_in_drop"), ((0.2, 0.0, 0.0), "run_in_length_m"), ((0.2, 0.5, -1.0), "wear_rate_per_m")],
)
def test_run_in_wear_factor_rejects_bad_parameters(args, match):
    with pytest.raises(ValueError, match=match):
        run_in_wear_factor(1.0, *args)
    with pytest.raises(ValueError, match="sliding distance"):
        run_in_wear_factor(-1.0, 0.2, 0.5, 0.0)
