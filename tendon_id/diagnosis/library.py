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
from tendon_id.errors import ConfigError

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
        y = residual.ravel()
        out = {}
        for c, label in enumerate(self.labels):
            x = self.columns[..., c].ravel()
            ok = np.isfinite(x) & np.isfinite(y)
            sx, sy = np.std(x[ok]), np.std(y[ok])
            out[label] = float(np.corrcoef(x[ok], y[ok])[0, 1]) if sx > 0 and sy > 0 else 0.0
        return out

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
        """
        import pysindy as ps

        y = residual.ravel()
        X = self.columns.reshape(-1, self.columns.shape[-1])
        ok = np.isfinite(y) & np.all(np.isfinite(X), axis=1)
        X, y = X[ok], y[ok]
        sd = X.std(axis=0)
        live = sd > 0
        if not live.any() or np.std(y) == 0:
            return None, {}
        Z = (X[:, live] - X[:, live].mean(axis=0)) / sd[live]
        yz = (y - y.mean()) / np.std(y)
        opt = ps.STLSQ(threshold=SPARSE_THRESHOLD, alpha=1e-3)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "eliminated all coefficients" is an answer here
            opt.fit(Z, yz.reshape(-1, 1))
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
