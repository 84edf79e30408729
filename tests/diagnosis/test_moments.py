"""Slice-by-slice moments (issue 42's scale) agree with numpy's whole-array ones, at any slice length."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from tendon_id.diagnosis import moments
from tendon_id.diagnosis.stats import frame_drops, frame_mean_squares
from tendon_id.errors import NonFiniteResult
from tendon_id.family import inputs as family_inputs

finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
with_nan = st.one_of(finite, st.just(np.nan))


def series(channels):
    return arrays(np.float64, st.tuples(st.integers(1, 60), st.just(channels)), elements=with_nan)


@pytest.fixture
def short_slices(monkeypatch):
    monkeypatch.setattr(family_inputs, "SLICE_FRAMES", 7)


@settings(max_examples=100, deadline=None)
@given(x=st.one_of(series(1), series(3)), slice_frames=st.integers(1, 70))
def test_moments_are_numpys_at_any_slice_length(x, slice_frames):
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(family_inputs, "SLICE_FRAMES", slice_frames)
        ok = np.isfinite(x)
        want_sum = float(np.sum(x[ok] ** 2))
        assert moments.nan_sum_square(x) == pytest.approx(want_sum, rel=1e-12, abs=1e-9)
        if ok.any():
            assert moments.nan_mean_square(x) == pytest.approx(want_sum / ok.sum(), rel=1e-12, abs=1e-12)
        else:  # undefined: refused, never a NaN result
            with pytest.raises(NonFiniteResult, match="no finite value"):
                moments.nan_mean_square(x)
        d = np.diff(x, axis=0)
        if np.isfinite(d).any():
            want = float(np.std(d[np.isfinite(d)]))
            assert moments.nan_std_of_differences(x) == pytest.approx(want, rel=1e-9, abs=1e-9)
        else:
            with pytest.raises(NonFiniteResult, match="no finite value"):
                moments.nan_std_of_differences(x)


@settings(max_examples=100, deadline=None)
@given(
    xy=st.integers(1, 60).flatmap(
        lambda n: st.tuples(
            arrays(np.float64, (n, 2), elements=with_nan), arrays(np.float64, (n, 2), elements=with_nan)
        )
    ),
    slice_frames=st.integers(1, 70),
)
def test_pearson_is_corrcoef_over_the_jointly_finite_entries(xy, slice_frames):
    x, y = xy
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(family_inputs, "SLICE_FRAMES", slice_frames)
        got = moments.nan_pearson(x, y)
    ok = np.isfinite(x) & np.isfinite(y)
    a, b = x[ok], y[ok]
    if a.size < 2 or np.ptp(a) == 0 or np.ptp(b) == 0:
        assert got == 0.0  # nothing to correlate, or a side that never moves
    else:
        assert got == pytest.approx(float(np.corrcoef(a, b)[0, 1]), abs=1e-9)


def test_pearson_refuses_unequal_shapes():
    with pytest.raises(ValueError, match="differ in shape"):
        moments.nan_pearson(np.zeros((3, 1)), np.zeros((4, 1)))


def test_frame_drops_are_the_whole_array_construction(short_slices):
    rng = np.random.default_rng(5)
    e0, e1 = rng.standard_normal((2, 100, 3))
    e0[:10] = np.nan  # a warm-up
    e1[rng.random((100, 3)) < 0.05] = np.nan
    sq = e0**2 - e1**2
    want = sq[np.isfinite(sq).all(axis=1)].mean(axis=1)
    np.testing.assert_array_equal(frame_drops(e0, e1), want)  # elementwise: the same bits
    ok = np.isfinite(e1).all(axis=1)
    np.testing.assert_array_equal(frame_mean_squares(e1), (e1[ok] ** 2).mean(axis=1))
