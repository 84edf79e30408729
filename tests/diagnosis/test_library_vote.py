"""The sparse vote on the square-root form of the least squares is STLSQ on every frame (issue 42's memory)."""

import warnings

import numpy as np
import pysindy as ps
import pytest

from tendon_id.diagnosis.library import SPARSE_THRESHOLD, Library


def vote_on_every_frame(lib: Library, residual):
    """The former vote: pysindy's STLSQ on the standardised frames themselves (the reference)."""
    y = residual.ravel()
    X = lib.columns.reshape(-1, lib.columns.shape[-1])
    ok = np.isfinite(y) & np.all(np.isfinite(X), axis=1)
    X, y = X[ok], y[ok]
    sd = X.std(axis=0)
    live = sd > 0
    Z = (X[:, live] - X[:, live].mean(axis=0)) / sd[live]
    opt = ps.STLSQ(threshold=SPARSE_THRESHOLD, alpha=1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        opt.fit(Z, ((y - y.mean()) / np.std(y)).reshape(-1, 1))
    coef = np.zeros(len(lib.labels))
    coef[live] = np.asarray(opt.coef_).ravel()
    weight = {}
    for c, e in enumerate(lib.effects):
        weight[e] = weight.get(e, 0.0) + abs(coef[c])
    total = sum(weight.values())
    return {e: w / total for e, w in weight.items()}


@pytest.mark.parametrize("seed", range(4))
def test_the_vote_on_the_square_root_form_is_the_vote_on_every_frame(seed, monkeypatch):
    from tendon_id.family import inputs as family_inputs

    monkeypatch.setattr(family_inputs, "SLICE_FRAMES", 777)  # several slices, one of them short
    rng = np.random.default_rng(seed)
    T, K = 5000, 3
    cols = rng.normal(size=(T, K, 5))
    cols[..., 1] += 0.8 * cols[..., 0]  # correlated columns, as signatures of one effect are
    cols[..., 4] = 0.0  # a column without spread
    lib = Library(labels=["a:x", "a:y", "b", "c", "d"], effects=["a", "a", "b", "c", "d"], columns=cols)
    true = np.roll([0.0, 0.0, 1.5, 0.3], seed)  # each seed lets another effect carry most of the residual
    true = np.r_[true, 0.0]
    residual = cols @ true + 0.5 * rng.normal(size=(T, K))
    residual[rng.integers(0, T, 40), 0] = np.nan  # warm-up frames
    vote, shares = lib.sparse_vote(residual)
    want = vote_on_every_frame(lib, residual)
    assert shares.keys() == want.keys()
    for e in want:
        assert shares[e] == pytest.approx(want[e], abs=1e-9), e
    assert vote == max(want, key=want.get) == {0: "b", 1: "c", 2: "a", 3: "a"}[seed]


def test_no_spread_no_vote():
    lib = Library(labels=["a"], effects=["a"], columns=np.ones((50, 1, 1)))
    assert lib.sparse_vote(np.arange(50.0)[:, None]) == (None, {})
    assert Library(labels=["a"], effects=["a"], columns=np.full((5, 1, 1), np.nan)).sparse_vote(np.ones((5, 1))) == (
        None,
        {},
    )
