"""The labelled library of signature regressors, their correlation with the residual, and the sparse vote.

Every candidate block has a signature, which its family computes
(:meth:`~tendon_id.family.Family.signatures`): the change of the predicted reading when the
block is added to the base at a typical magnitude.  The residual of a base that lacks the effect is,
to first order, a multiple
of it.  A sparse regression of the residual on all the columns (pysindy's sequentially
thresholded least squares, Brunton, Proctor & Kutz 2016) keeps the few columns that
explain it; the effect whose columns carry most of the fitted residual is the vote, an
independent check on the ranking by refits.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tendon_id.checks import check_choices
from tendon_id.diagnosis.moments import nan_pearson
from tendon_id.errors import ConfigError
from tendon_id.family.inputs import frame_slices

#: STLSQ threshold on standardised coefficients: a column must move the standardised
#: residual by 5 % of its spread per standard deviation to stay in the model.
SPARSE_THRESHOLD = 0.05
#: Subsampled points per residual-against-regressor plot.
PLOT_POINTS = 3000


def candidate_names(spec: str | Sequence[str] | None, known) -> list[str]:
    """Validated candidate effect names among ``known`` (a family's blocks), default all of them.

    ``spec`` is a comma-separated string or a sequence; each name once, in the order given.
    """
    if spec is None:
        return list(known)
    names = [p.strip() for p in spec.split(",")] if isinstance(spec, str) else [str(p) for p in spec]
    names = [n for n in names if n]
    if not names:
        raise ConfigError(f"no candidate effect given; known: {', '.join(known)}", param="candidates")
    return check_choices("candidates", names, known, what="candidate effect")


@dataclass(frozen=True)
class Library:
    """Signature columns on some frames.

    Attributes
    ----------
    labels : list of str
        ``effect`` or ``effect:param`` per column.
    effects : list of str
        The effect of each column.
    columns : ndarray, shape (T, K, C)
        Change of the predicted reading (K channels: a snake's three tendons, a passage's one
        side) per column [the family's unit].
    """

    labels: list
    effects: list
    columns: NDArray

    def correlations(self, residual: NDArray) -> dict[str, float]:
        """Pearson correlation of the residual with each column, over frames and tendons."""
        # Slice by slice (moments.nan_pearson): no copies of the column and the residual per frame.
        return {label: nan_pearson(self.columns[..., c], residual) for c, label in enumerate(self.labels)}

    def effect_correlation(self, residual: NDArray) -> dict[str, float]:
        """Per effect, the largest absolute correlation of its columns with the residual."""
        corr = self.correlations(residual)
        out: dict[str, float] = {}
        for label, effect in zip(self.labels, self.effects):
            out[effect] = max(out.get(effect, 0.0), abs(corr[label]))
        return out

    def sparse_vote(self, residual: NDArray) -> tuple[str | None, dict[str, float]]:
        """The effect whose columns a sparse regression of the residual keeps with most weight.

        Returns the vote (None when no column survives) and each effect's share of the
        fitted residual's sum of absolute standardised contributions.

        The regression of the standardised residual ``y`` on the standardised columns ``Z``
        (T rows) is run on their square-root form instead: with ``Z^T Z = R^T R`` and
        ``R^T q = Z^T y``, ``|Z w - y|^2 = |R w - q|^2 + const`` for every ``w``, so each of
        STLSQ's ridge and least-squares steps has the same minimiser on the C rows of ``R`` as on
        the T frames (the least squares' normal equations, Golub & Van Loan 2013, "Matrix
        Computations", 4th ed., section 5.3). The sums are taken slice by slice: no copy of the
        columns per frame (issue 42's scale).
        """
        import pysindy as ps

        moments = _moments(self.columns.reshape(-1, self.columns.shape[-1]), residual.ravel())
        if moments is None:
            return None, {}
        n, sd, sd_y, Cxx, Cxy = moments
        live = sd > 0
        if not live.any() or sd_y == 0:
            return None, {}
        G = Cxx[np.ix_(live, live)] / np.outer(sd[live], sd[live])  # Z^T Z
        b = Cxy[live] / (sd[live] * sd_y)  # Z^T y
        lam, V = np.linalg.eigh(G)
        keep = lam > lam.max() * 1e-12
        R = np.sqrt(lam[keep])[:, None] * V[:, keep].T
        q = (V[:, keep].T @ b) / np.sqrt(lam[keep])
        opt = ps.STLSQ(threshold=SPARSE_THRESHOLD, alpha=1e-3)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "eliminated all coefficients" is an answer here
            opt.fit(R, q.reshape(-1, 1))
        coef = np.zeros(len(self.labels))
        coef[live] = np.asarray(opt.coef_).ravel()
        weight: dict[str, float] = {}
        for c, effect in enumerate(self.effects):
            weight[effect] = weight.get(effect, 0.0) + abs(coef[c])
        total = sum(weight.values())
        if total == 0:
            return None, {e: 0.0 for e in weight}
        shares = {e: w / total for e, w in weight.items()}
        return max(shares, key=shares.get), shares

    def plot_data(self, residual: NDArray, effects: list[str], rng) -> dict:
        """The residual and the columns of ``effects`` at PLOT_POINTS random entries, for the report."""
        n = residual.size
        pick = np.sort(rng.choice(n, size=min(PLOT_POINTS, n), replace=False))
        out = {"residual": residual.ravel()[pick]}
        for c, (label, effect) in enumerate(zip(self.labels, self.effects)):
            if effect in effects:
                out[label] = self.columns[..., c].ravel()[pick]
        return out


def _moments(X: NDArray, y: NDArray):
    """Over the rows where ``X`` and ``y`` are finite: their count, the columns' and ``y``'s standard
    deviations, and the centred sums ``(X - m)^T (X - m)`` and ``(X - m)^T (y - m_y)``; None without rows.

    Two passes over slices of :data:`~tendon_id.family.inputs.SLICE_FRAMES` rows (the means, then the
    centred sums, as ``np.std`` centres before it squares).
    """
    c = X.shape[1]
    slices = list(frame_slices(len(y)))
    n, sx, sy = 0, np.zeros(c), 0.0
    for s in slices:
        ok = np.isfinite(y[s]) & np.all(np.isfinite(X[s]), axis=1)
        n += int(ok.sum())
        sx += X[s][ok].sum(axis=0)
        sy += float(y[s][ok].sum())
    if n == 0:
        return None
    mx, my = sx / n, sy / n
    Cxx, Cxy, Cyy = np.zeros((c, c)), np.zeros(c), 0.0
    for s in slices:
        ok = np.isfinite(y[s]) & np.all(np.isfinite(X[s]), axis=1)
        xc, yc = X[s][ok] - mx, y[s][ok] - my
        Cxx += xc.T @ xc
        Cxy += xc.T @ yc
        Cyy += float(yc @ yc)
    return n, np.sqrt(np.diag(Cxx) / n), np.sqrt(Cyy / n), Cxx, Cxy
