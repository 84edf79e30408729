"""The compiled play-operator loops give the numpy scans' bits, and fall back to them where they must."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from friction_models import kernels
from friction_models.kernels import play_scan, play_series
from friction_models.scan import clamp_prefix

finite = st.floats(-5, 5, allow_nan=False, allow_infinity=False)
positive = st.floats(0, 1, allow_nan=False, allow_infinity=False)


def reference_scan(lo, hi, reset, start):
    """The clamp scan of friction_models.scan, as play_output ran before the compiled loop."""
    step_hi = np.where(reset.reshape((-1,) + (1,) * (lo.ndim - 1)), lo, hi)
    p_lo, p_hi = clamp_prefix(lo, step_hi)
    return np.minimum(np.maximum(start, p_lo), p_hi)


def reference_series(log_in, phi, n_pass, reset):
    """Guide after guide with the reference scan; NaN beyond a column's last guide."""
    x = log_in.copy()
    chain = np.full(phi.shape, np.nan)
    first = reset.copy()
    first[0] = True
    for g in range(phi.shape[1]):
        cols = n_pass > g
        lo, hi = x[:, cols] - phi[:, g, cols], x[:, cols] + phi[:, g, cols]
        x[:, cols] = reference_scan(lo, hi, first, lo[0])
        chain[:, g, cols] = x[:, cols]
    return x, chain


@settings(max_examples=150, deadline=None)
@given(x=arrays(float, st.tuples(st.integers(1, 60), st.integers(1, 3)), elements=finite), data=st.data())
def test_compiled_scan_equals_the_clamp_scan_bit_for_bit(x, data):
    phi = data.draw(arrays(float, x.shape, elements=positive))
    reset = data.draw(arrays(bool, x.shape[:1]))
    start = data.draw(arrays(float, x.shape[1:], elements=finite))
    lo, hi = x - phi, x + phi
    np.testing.assert_array_equal(play_scan(lo, hi, reset, start), reference_scan(lo, hi, reset, start))


@settings(max_examples=150, deadline=None)
@given(
    log_in=arrays(float, st.tuples(st.integers(1, 50), st.integers(1, 4)), elements=finite),
    k=st.integers(1, 5),
    data=st.data(),
)
def test_guides_in_series_equal_one_scan_per_guide(log_in, k, data):
    t, m = log_in.shape
    phi = data.draw(arrays(float, (t, k, m), elements=positive))
    n_pass = data.draw(arrays(np.int64, (m,), elements=st.integers(0, k)))
    reset = data.draw(arrays(bool, (t,)))
    final, chain = play_series(log_in, phi, n_pass, reset, keep_chain=True)
    want_final, want_chain = reference_series(log_in, phi, n_pass, reset)
    np.testing.assert_array_equal(final, want_final)
    np.testing.assert_array_equal(chain, want_chain)  # NaN beyond each column's last guide, in both
    only_final, none = play_series(log_in, phi, n_pass, reset)
    assert none is None
    np.testing.assert_array_equal(only_final, want_final)


def test_a_nan_edge_gives_numpys_answer():
    # The clamp scan carries a NaN on through its prefix compositions; the compiled loop hands
    # such data to the scan, so both routes agree on it too.
    lo = np.array([[0.0], [np.nan], [0.1], [0.2], [0.0]])
    hi = lo + 0.5
    reset = np.array([True, False, False, True, False])
    got = play_scan(lo, hi, reset, np.zeros(1))
    np.testing.assert_array_equal(got, reference_scan(lo, hi, reset, np.zeros(1)))
    assert np.isnan(got[1:3]).all() and np.isfinite(got[0]).all()


@pytest.mark.skipif(not kernels.COMPILED, reason="numba is not installed")
def test_without_numba_the_same_functions_run_the_scans(monkeypatch):
    rng = np.random.default_rng(0)
    log_in = rng.normal(size=(40, 3))
    phi = rng.uniform(0, 0.3, size=(40, 4, 3))
    reset = rng.random(40) < 0.1
    compiled = play_series(log_in, phi, np.array([4, 2, 0]), reset, keep_chain=True)
    monkeypatch.setattr(kernels, "COMPILED", False)
    fallback = play_series(log_in, phi, np.array([4, 2, 0]), reset, keep_chain=True)
    for a, b in zip(compiled, fallback):
        np.testing.assert_array_equal(a, b)


@settings(max_examples=100, deadline=None)
@given(
    log_in=arrays(float, st.tuples(st.integers(1, 40), st.integers(1, 4)), elements=finite),
    k=st.integers(1, 4),
    data=st.data(),
)
def test_a_start_share_restarts_each_guide_inside_its_band_on_both_routes(log_in, k, data):
    t, m = log_in.shape
    phi = data.draw(arrays(float, (t, k, m), elements=positive))
    reset = data.draw(arrays(bool, (t,)))
    start = data.draw(arrays(float, (t, m), elements=st.floats(0.0, 1.0)))
    n_pass = np.full(m, k)
    final, chain = play_series(log_in, phi, n_pass, reset, keep_chain=True, start=start)
    # at the first frame each guide sits at the share `start` of the band around its input
    x = log_in[0].copy()
    for g in range(k):
        p = phi[0, g]
        x = x - p + start[0] * 2 * p
        np.testing.assert_allclose(chain[0, g], x, rtol=1e-12, atol=1e-12)
    if kernels.COMPILED:  # the numpy route agrees (switched by hand: hypothesis runs many examples per fixture)
        kernels.COMPILED = False
        try:
            fallback = play_series(log_in, phi, n_pass, reset, start=start)[0]
        finally:
            kernels.COMPILED = True
        np.testing.assert_allclose(fallback, final, rtol=0, atol=1e-12)
    # share 0 is the taut start, bit for bit
    np.testing.assert_array_equal(
        play_series(log_in, phi, n_pass, reset, start=np.zeros((t, m)))[0], play_series(log_in, phi, n_pass, reset)[0]
    )
