"""The gap map and its bootstrap, made with one whole-length temporary at a time (issue 42), give the bits
of the direct construction: residual**2 kept, NaN-filled copies, nanmean, a cumsum and its copy."""

from __future__ import annotations

import numpy as np
import pytest

from tendon_id.diagnosis.stats import block_bootstrap_means, bootstrap_ci
from tendon_id.diagnosis.where import gap_map


def direct_bootstrap_means(x, block, n_boot, rng):
    """Künsch's moving blocks with the block sums from ``np.r_[0, cumsum(x)]`` (the former construction)."""
    n = len(x)
    block = int(min(max(block, 1), n))
    n_blocks = -(-n // block)
    csum = np.r_[0.0, np.cumsum(x)]
    starts = rng.integers(0, n - block + 1, size=(n_boot, n_blocks))
    sums = csum[starts + block] - csum[starts]
    last = n - block * (n_blocks - 1)
    sums[:, -1] = csum[starts[:, -1] + last] - csum[starts[:, -1]]
    return sums.sum(axis=1) / n


def direct_gap_map(residual, masks, block, n_boot, level, rng):
    """(name, share_error, share_frames, bias, bias_ci) by the direct construction."""
    sq = residual**2
    total = float(np.nansum(sq))
    valid = np.isfinite(residual)
    n_all = int(valid.sum())
    rows = []
    for name, _, mask in masks:
        m = np.broadcast_to(mask if mask.ndim == 2 else mask[:, None], residual.shape) & valid
        if not m.any():
            continue
        per_frame = np.nanmean(np.where(m, residual, np.nan)[m.any(axis=1)], axis=1)
        means = direct_bootstrap_means(per_frame, block, n_boot, rng)
        tail = 50.0 * (1.0 - level)
        ci = tuple(float(v) for v in np.percentile(means, [tail, 100.0 - tail]))
        rows.append((name, float(np.nansum(sq[m]) / total), float(m.sum() / n_all), float(np.nanmean(residual[m])), ci))
    return rows


@pytest.mark.parametrize("channels", [1, 3])
def test_gap_map_is_the_direct_construction_bit_for_bit(channels):
    rng = np.random.default_rng(channels)
    r = rng.standard_normal((4000, channels))
    r[:150] = np.nan  # a warm-up
    r[rng.random(r.shape) < 0.05] = np.nan
    masks = [
        ("by frame", "k", rng.random(4000) < 0.3),
        ("by channel", "k", rng.random((4000, channels)) < 0.5),
        ("in the warm-up only", "k", np.arange(4000) < 100),  # no valid frame: no row
    ]
    got = gap_map(None, r, iter(masks), block=25, n_boot=300, level=0.9, rng=np.random.default_rng(7))
    want = direct_gap_map(r, masks, 25, 300, 0.9, np.random.default_rng(7))
    assert [(s.stratum, s.share_error, s.share_frames, s.bias, s.bias_ci) for s in got] == want
    assert [s.stratum for s in got] == ["by frame", "by channel"]


def test_bootstrap_means_are_the_direct_construction_bit_for_bit():
    x = np.random.default_rng(3).standard_normal(1001)
    for block in (1, 7, 1001):
        want = direct_bootstrap_means(x, block, 200, np.random.default_rng(block))
        got = block_bootstrap_means(x, block, 200, np.random.default_rng(block))
        np.testing.assert_array_equal(got, want)
        own = x.copy()  # the cumulative sums in the caller's array: the same bits, and x itself untouched above
        np.testing.assert_array_equal(block_bootstrap_means(own, block, 200, np.random.default_rng(block), True), want)
        np.testing.assert_array_equal(own, np.cumsum(x))
    assert np.isfinite(bootstrap_ci(x, 7, 200, 0.9, np.random.default_rng(0))).all()
