"""The play operator's state (friction_models.play_state): batch equals streaming; each number means what it says."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from friction_models.play_operator import play_output
from friction_models.play_state import PlayStateStream, play_state

DT = 0.1


def _edges(x: np.ndarray, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return x - phi, x + phi


@settings(max_examples=40, deadline=None)
@given(
    st.integers(min_value=0, max_value=2**31 - 1),
    st.integers(min_value=2, max_value=60),
    st.lists(st.integers(min_value=1, max_value=59), max_size=3),
)
def test_streaming_state_equals_batch_state(seed, t, cuts):
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.normal(0, 0.08, (t, 2, 3)), axis=0) + 4.0
    x[rng.random(t) < 0.3] = x[0]  # holds: repeated inputs, as encoders quantise angles
    phi = rng.uniform(0.0, 0.2, (t, 2, 3)) * (rng.random((t, 2, 3)) > 0.1)  # some guides out of contact
    reset = np.zeros(t, bool)
    reset[0] = True
    reset[[c for c in cuts if c < t]] = True
    lo, hi = _edges(x, phi)
    y = play_output(lo, hi, reset)
    batch = play_state(y, lo, hi, reset, DT)
    stream = PlayStateStream((2, 3), DT)
    for k in range(t):
        if reset[k]:
            stream.reset()
        y_k, s_k = stream.step(lo[k], hi[k])
        np.testing.assert_array_equal(y_k, y[k])
        np.testing.assert_allclose(s_k, batch[k], atol=1e-9)


def test_state_of_a_ramp_a_hold_and_a_reversal():
    """Up by two bands (forward slip), hold (stuck on the edge), down by half a band (stuck inside)."""
    phi = 0.1
    x = np.r_[np.linspace(4.0, 4.4, 5), [4.4] * 3, [4.35, 4.3]]
    reset = np.zeros(len(x), bool)
    reset[0] = True
    lo, hi = _edges(x, np.full_like(x, phi))
    y = play_output(lo, hi, reset)
    s = play_state(y, lo, hi, reset, DT)
    sigma, position, since, sweep = s.T
    np.testing.assert_array_equal(sigma[:8], 1.0)  # on the forward edge while pulled and while held there
    np.testing.assert_allclose(position[:8], 0.0, atol=1e-12)
    np.testing.assert_array_equal(sigma[8:], 0.0)  # the reversal is inside the band: stuck
    np.testing.assert_allclose(position[8:], [0.25, 0.5], atol=1e-12)
    np.testing.assert_allclose(since[:5], 0.0)  # sliding every frame of the ramp
    np.testing.assert_allclose(since[5:], np.log1p(DT * np.arange(1, 6)))  # not since
    np.testing.assert_allclose(sweep[:3], [0.0, 0.5, 1.0])  # the band (0.2 wide) is crossed at the third frame
    np.testing.assert_allclose(sweep[3:], 1.0)


def test_a_new_trajectory_forgets_the_last_one():
    x = np.r_[np.linspace(4.0, 5.0, 6), np.linspace(4.0, 4.05, 3)]
    reset = np.zeros(len(x), bool)
    reset[[0, 6]] = True
    lo, hi = _edges(x, np.full_like(x, 0.2))
    s = play_state(play_output(lo, hi, reset), lo, hi, reset, DT)
    assert s[5, 3] == 1.0 and s[6, 3] == 0.0  # the sweep restarts
    assert s[6, 2] == 0.0  # and so does the clock


def test_a_guide_out_of_contact_is_forward_slip_with_nothing_to_forget():
    x = np.linspace(4.0, 4.1, 4)
    lo = hi = x
    s = play_state(play_output(lo, hi, np.r_[True, False, False, False]), lo, hi, np.r_[True, False, False, False], DT)
    np.testing.assert_array_equal(s[:, 0], 1.0)
    np.testing.assert_array_equal(s[:, 1], 0.0)
    np.testing.assert_array_equal(s[:, 3], 1.0)
