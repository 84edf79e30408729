import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from friction_models import play_operator, play_operator_edges, slip_state

finite = st.floats(-5, 5, allow_nan=False, allow_infinity=False)
positive = st.floats(0, 1, allow_nan=False, allow_infinity=False)


def sequential(x, phi, reset):
    """The play operator written as the textbook loop."""
    y = np.empty_like(x)
    for t in range(len(x)):
        if t == 0 or reset[t]:
            y[t] = x[t] - phi[t]
        else:
            y[t] = min(max(y[t - 1], x[t] - phi[t]), x[t] + phi[t])
    return y


@settings(max_examples=200, deadline=None)
@given(
    x=arrays(float, st.integers(1, 80), elements=finite),
    data=st.data(),
)
def test_scan_equals_sequential_loop_bit_for_bit(x, data):
    phi = data.draw(arrays(float, x.shape, elements=positive))
    reset = data.draw(arrays(bool, x.shape))
    res = play_operator(x, phi, reset=reset)
    np.testing.assert_array_equal(res.log_out, sequential(x, phi, reset))


@settings(max_examples=200, deadline=None)
@given(x=arrays(float, st.integers(1, 60), elements=finite), data=st.data())
def test_output_stays_in_the_capstan_cone_and_sigma_names_the_edge(x, data):
    phi = data.draw(arrays(float, x.shape, elements=positive))
    res = play_operator(x, phi)
    assert np.all(res.log_out >= x - phi) and np.all(res.log_out <= x + phi)
    lower = res.log_out == x - phi
    upper = (res.log_out == x + phi) & ~lower
    assert np.all(res.sigma[lower] == 1)
    assert np.all(res.sigma[upper] == -1)
    assert np.all(res.sigma[~lower & ~upper] == 0)


@settings(max_examples=100, deadline=None)
@given(x=arrays(float, st.integers(2, 40), elements=finite), data=st.data())
def test_rate_independence(x, data):
    # A hysteresis operator ignores how fast its input is traversed: holding every
    # frame twice gives every output twice.
    phi = np.full(x.shape, data.draw(positive))
    once = play_operator(x, phi).log_out
    twice = play_operator(np.repeat(x, 2), np.repeat(phi, 2)).log_out
    np.testing.assert_array_equal(twice, np.repeat(once, 2))


def test_monotone_pull_is_forward_slip_and_release_reverses():
    x = np.concatenate([np.linspace(4.0, 5.0, 50), np.linspace(5.0, 4.0, 50)])
    phi = np.full_like(x, 0.1)
    res = play_operator(x, phi)
    assert np.all(res.sigma[:50] == 1)
    np.testing.assert_allclose(res.log_out[:50], x[:50] - 0.1)
    # On release the output first sticks (the cone is 0.2 wide), then slides back.
    assert res.sigma[50] in (0, 1) and np.all(res.sigma[52:60] == 0)
    assert np.all(res.sigma[-10:] == -1)
    np.testing.assert_allclose(res.log_out[-10:], x[-10:] + 0.1)


def test_reset_restarts_on_the_forward_slip_edge():
    x = np.array([5.0, 4.5, 4.9, 4.7])
    phi = np.full(4, 0.3)
    res = play_operator(x, phi, reset=np.array([True, False, True, False]))
    assert res.log_out[2] == x[2] - 0.3


def test_leading_axes_are_vectorised():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(30, 4, 3))
    phi = rng.uniform(0, 0.2, size=(30, 4, 3))
    full = play_operator(x, phi).log_out
    for a in range(4):
        for b in range(3):
            np.testing.assert_array_equal(full[:, a, b], sequential(x[:, a, b], phi[:, a, b], np.zeros(30, bool)))


def test_bad_inputs_are_refused():
    with pytest.raises(ValueError, match="non-negative"):
        play_operator(np.zeros(3), -np.ones(3))
    with pytest.raises(ValueError, match="lo <= hi"):
        play_operator_edges(np.ones(3), np.zeros(3))
    with pytest.raises(ValueError, match="reset"):
        play_operator(np.zeros(3), np.zeros(3), reset=np.zeros(2, bool))


def test_slip_state_zero_width_cone_is_forward_slip():
    assert slip_state(np.array([1.0]), np.array([1.0]), np.array([1.0]))[0] == 1


@pytest.mark.parametrize("n", [65, 1000, 4097])
def test_blocked_scan_on_long_inputs_equals_the_loop(n):
    rng = np.random.default_rng(n)
    x = np.cumsum(rng.normal(size=(n, 2)) * 0.05, axis=0)
    phi = rng.uniform(0, 0.1, size=(n, 2))
    reset = rng.uniform(size=n) < 0.01
    res = play_operator(x, phi, reset=reset)
    for c in range(2):
        np.testing.assert_array_equal(res.log_out[:, c], sequential(x[:, c], phi[:, c], reset))
