"""The Ljung–Box p-value by lagged dot products agrees with statsmodels' ``acorr_ljungbox`` and its FFT ``acf``."""

import numpy as np
import pytest
from statsmodels.stats.diagnostic import acorr_ljungbox

from tendon_id.diagnosis.stats import ljung_box_p


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ljung_box_p_agrees_with_statsmodels(seed):
    rng = np.random.default_rng(seed)
    white = rng.normal(size=3000)
    ar = np.empty(3000)  # an AR(1) residual: something systematic left
    ar[0] = 0.0
    for t in range(1, ar.size):
        ar[t] = 0.3 * ar[t - 1] + rng.normal()
    both = np.column_stack([white, ar])
    got = ljung_box_p(both, lags=10)
    want = [float(acorr_ljungbox(c - c.mean(), lags=[10])["lb_pvalue"].iloc[0]) for c in both.T]
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-300)
    from scipy.stats import chi2
    from statsmodels.tsa.stattools import acf

    n, k = 3000, np.arange(1, 11)
    r = [acf(c - c.mean(), nlags=10, fft=True)[1:] for c in both.T]
    by_fft = [chi2.sf(n * (n + 2) * np.sum(rc**2 / (n - k)), 10) for rc in r]
    np.testing.assert_allclose(got, by_fft, rtol=1e-9, atol=1e-300)
    assert got[1] < 1e-6 < got[0]  # the AR(1) column is not white


def test_ljung_box_p_skips_non_finite_and_constant():
    x = np.r_[np.nan, np.arange(50.0) % 7]
    assert np.isnan(ljung_box_p(np.ones((40, 1)))[0])  # constant: undefined
    assert np.isnan(ljung_box_p(np.arange(5.0)[:, None], lags=10)[0])  # too short
    assert 0.0 <= ljung_box_p(x[:, None])[0] <= 1.0  # the NaN frame is left out
