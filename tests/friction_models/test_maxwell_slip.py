"""The smooth edge of the stick/slip band: a sum of play operators of several widths."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from friction_models import maxwell_slip, play_operator_edges
from friction_models.maxwell_slip import element_factors

finite = st.floats(-3.0, 3.0, allow_nan=False)
paths = arrays(np.float64, st.integers(2, 120), elements=finite)
widths = st.floats(0.0, 1.0)


def _band(x, data):
    """A driving path ``x`` with a band of half-width in [0, 0.5] that varies per frame, and some resets."""
    h = data.draw(arrays(np.float64, x.shape, elements=st.floats(0.0, 0.5)))
    reset = data.draw(arrays(np.bool_, x.shape))
    return x - h, x + h, reset


@settings(max_examples=60, deadline=None)
@given(paths, widths, st.data())
def test_output_stays_within_the_band(x, w, data):
    lo, hi, reset = _band(x, data)
    res = maxwell_slip(lo, hi, w, reset)
    assert np.all(res.log_out >= lo) and np.all(res.log_out <= hi)
    assert set(np.unique(res.sigma)) <= {-1, 0, 1}


@settings(max_examples=60, deadline=None)
@given(paths, widths, st.data())
def test_no_jump_larger_than_the_edges_move(x, w, data):
    """Continuity: a step moves the output by at most what it moves the elements' edges (no jump at reversals)."""
    lo, hi, reset = _band(x, data)
    y = maxwell_slip(lo, hi, w, reset).log_out
    c, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
    step = np.abs(np.diff(c)) + (1.0 + w) * np.abs(np.diff(h))
    moved = np.abs(np.diff(y))[~reset[1:]]
    assert np.all(moved <= step[~reset[1:]] + 1e-12)


@settings(max_examples=60, deadline=None)
@given(paths, widths, st.data())
def test_tends_to_the_sharp_play_operator(x, w, data):
    """Every element's edges lie within ``w h`` of the band's, so the output within ``w max(h)`` of the play's."""
    lo, hi, reset = _band(x, data)
    sharp = play_operator_edges(lo, hi, reset).log_out
    smooth = maxwell_slip(lo, hi, w, reset).log_out
    assert np.max(np.abs(smooth - sharp)) <= w * np.max(0.5 * (hi - lo)) + 1e-12


def test_zero_width_is_the_play_operator_exactly():
    x = np.sin(np.linspace(0, 12, 300))
    a = maxwell_slip(x - 0.2, x + 0.2, 0.0)
    b = play_operator_edges(x - 0.2, x + 0.2)
    np.testing.assert_array_equal(a.log_out, b.log_out)
    np.testing.assert_array_equal(a.sigma, b.sigma)


def test_after_a_reversal_slip_sets_in_between_one_minus_and_one_plus_the_width():
    """Band 2h = 1 on a ramp up then down: the output holds until 1 - w of the band is crossed, slides after 1 + w."""
    w, h = 0.3, 0.5
    x = np.r_[np.linspace(0.0, 2.0, 201), np.linspace(1.99, -1.0, 300)]
    res = maxwell_slip(x - h, x + h, w)
    y, top = res.log_out, 200
    assert y[top] == pytest.approx(x[top] - h)  # pulled: forward slip on the lower edge
    back = x[top] - x[top:]  # how far the driving side has come back
    held = back <= 2 * h * (1 - w) - 1e-9
    np.testing.assert_allclose(y[top:][held], y[top], atol=1e-12)  # stick
    sliding = back >= 2 * h * (1 + w) + 1e-9
    np.testing.assert_allclose(y[top:][sliding], (x + h)[top:][sliding], atol=1e-12)  # on the upper edge
    between = ~held & ~sliding
    assert np.all(np.diff(y[top:][between]) <= 0)  # joining it gradually: the elements slip one by one
    first, last = 2 * h * element_factors(w)[[0, -1]]  # the K half-widths: midpoints of K parts of (1 - w, 1 + w)
    assert np.all(np.diff(y[top:][(back > first + 0.01) & (back < last)]) < 0)
    assert np.all(res.sigma[top:][sliding] == -1) and np.all(res.sigma[top:][held & (back > 0)] == 0)


def test_reset_starts_on_the_forward_edge_and_axes_are_vectorised():
    t = np.linspace(0, 6, 200)
    x = np.stack([np.sin(t), np.cos(t), 0.5 * np.sin(2 * t)], axis=1)[:, :, None] * np.ones((1, 1, 2))
    reset = np.zeros(200, bool)
    reset[100] = True
    res = maxwell_slip(x - 0.3, x + 0.3, 0.4, reset)
    assert res.log_out.shape == x.shape
    np.testing.assert_allclose(res.log_out[[0, 100]], (x - 0.3)[[0, 100]])
    one = maxwell_slip(x[:, 1, 0] - 0.3, x[:, 1, 0] + 0.3, 0.4, reset).log_out
    np.testing.assert_array_equal(res.log_out[:, 1, 0], one)
    assert element_factors(0.4).mean() == pytest.approx(1.0)


def test_bad_inputs_are_refused():
    x = np.zeros(5)
    with pytest.raises(ValueError, match="width"):
        maxwell_slip(x, x + 1, -0.1)
    with pytest.raises(ValueError, match="width"):
        maxwell_slip(x, x + 1, 1.5)
    with pytest.raises(ValueError, match="lo <= hi"):
        maxwell_slip(x + 1, x, 0.2)
    with pytest.raises(ValueError, match="elements"):
        maxwell_slip(x, x + 1, 0.2, elements=0)
