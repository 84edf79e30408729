"""The paired test's null: how much a structure's refit gains over the base's where the base is the truth.

A model fed measured inputs is not the best predictor of the label: the noise it reads
drags a stick band's edge (a ratchet, :func:`~tendon_id.zoo.snake.diagnosis.noise_floor`),
and a refit's free parameters absorb part of that in ways that depend on the block. On the
benchmark's null cases a refitted bending loss, which widens every band by a tension-independent
amount, lowered the held-out mean squared error by up to 32 % although no backbone
stiffness was simulated, while a refitted clock skew gained under 1 %. One fixed margin
cannot serve both: it either names the loss on null data or misses a real skew.

So the paired test is calibrated by a parametric bootstrap (Efron & Tibshirani 1993, ch. 6):
each draw simulates the training and held-out frames of every split from the base's fit
(:meth:`~tendon_id.family.Family.simulate_null`), refits the base and the structure on them,
and records ``log(mse_base / mse_structure)`` on the simulated held-out frames. The bound is
the upper prediction bound of one more draw (Student's t with ``draws - 1`` degrees of
freedom, Hahn & Meeker 1991, sec. 4.6), which accounts for the few draws. The simulated
clean inputs are smoother than the truth's, so a noise-absorbing block gains less on them
than on real noise; the margin is ``exp(null_scale * bound) - 1``
(:class:`~tendon_id.diagnosis.DiagnosisSettings`: the factor and how it was measured). A
block that gains nothing on null data, a clock skew, then needs a few per cent, and a bending
loss some 20 to 60 %.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from tendon_id.diagnosis.runner import Scorer

__all__ = ["NullDraws", "NullGain", "calibrated_margins", "prediction_bound"]


@dataclass(frozen=True)
class NullGain:
    """What a structure's refit gains over the base's on data simulated from the base's fit.

    Attributes
    ----------
    effects : tuple of str
        The effects the structure adds to the base.
    log_ratios : tuple of float
        Per draw, ``log(mse_base / mse_structure)`` on the simulated held-out frames [-].
    level : float
        One-sided level of the bound [-].
    bound : float
        The prediction bound of one more draw's log ratio at ``level`` [-].
    scale : float
        Factor on the bound (:attr:`~tendon_id.diagnosis.DiagnosisSettings.null_scale`) [-].
    """

    effects: tuple
    log_ratios: tuple
    level: float
    bound: float
    scale: float = 1.0

    @property
    def margin(self) -> float:
        """The share by which the structure must lower the base's mean squared error to show a gap [-]."""
        return float(np.expm1(max(self.scale * self.bound, 0.0)))

    def to_dict(self) -> dict:
        return {
            "effects": list(self.effects),
            "log_ratios": list(self.log_ratios),
            "level": self.level,
            "bound": self.bound,
            "scale": self.scale,
            "margin": self.margin,
        }


def prediction_bound(x, level: float) -> float:
    """Upper ``level`` bound of one more draw from the normal sample ``x``: ``mean + t sd sqrt(1 + 1/n)``."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    return float(x.mean() + stats.t.ppf(level, n - 1) * x.std(ddof=1) * np.sqrt(1.0 + 1.0 / n))


class NullDraws:
    """Data simulated from the base's fit, the base refitted on each draw: what a structure's null gain is read on.

    Use :meth:`simulate`, then :meth:`gain` per structure: the draws and the base's refits are
    shared by every structure measured on them.

    Attributes
    ----------
    simulated : list of Split
        ``null_draws`` draws of every split, draw by draw.
    mse_base : ndarray, shape (draws,)
        The refitted base's held-out mean squared error on each draw [unit^2].
    """

    def __init__(self, family, simulated: list, n_splits: int, draws: int, scorer: Scorer, scale: float):
        self.family, self.simulated, self.n_splits, self.draws, self.scorer = family, simulated, n_splits, draws, scorer
        self.scale = scale
        # Each draw's held-out frames: the simulated test sets of its splits, concatenated in order.
        self.edges = np.cumsum([0] + [s.test.n_frames for s in simulated])
        self.mse_base = np.empty(0)

    @classmethod
    def simulate(
        cls, family, splits: list, base, base_fits: list, settings, rng, *, n_jobs=1, progress=None
    ) -> NullDraws | None:
        """Simulate ``settings.null_draws`` draws of every split from ``base_fits`` and refit ``base`` on each
        (None where the family cannot simulate its sensors)."""
        draws = settings.null_draws
        per_split = [family.simulate_null(split, base_fits[k].model, rng, draws) for k, split in enumerate(splits)]
        if any(p is None for p in per_split):
            return None
        simulated = [per_split[k][d] for d in range(draws) for k in range(len(splits))]
        scorer = Scorer(family, simulated, settings, n_jobs=n_jobs, progress=progress, tol=settings.null_tol)
        out = cls(family, simulated, len(splits), draws, scorer, settings.null_scale)
        out.mse_base = out.draw_mse(out.refit(base, base_fits, "null draws: base"))
        return out

    def refit(self, structure, fits: list, desc: str):
        """Held-out residual of ``structure`` refitted on every draw from its fit on the split (``fits``)."""
        starts = [[self.family.start(fits[k].model) for _ in range(self.draws) for k in range(self.n_splits)]]
        return self.scorer.score([structure], starts, desc)[0].residual

    def draw_mse(self, residual) -> np.ndarray:
        n = self.n_splits
        return np.array(
            [np.nanmean(residual[self.edges[d * n] : self.edges[(d + 1) * n]] ** 2) for d in range(self.draws)]
        )

    def gain(self, effects: tuple, structure, fits: list, level: float) -> NullGain:
        """The null gain of ``structure`` (adding ``effects``), refitted from ``fits``, bounded at ``level``."""
        ratios = np.log(
            self.mse_base / self.draw_mse(self.refit(structure, fits, "null draws: " + " + ".join(effects)))
        )
        bound = prediction_bound(ratios, level)
        return NullGain(tuple(effects), tuple(float(r) for r in ratios), level, bound, self.scale)


def calibrated_margins(
    family,
    splits: list,
    base,
    base_score,
    run,
    blocks: dict,
    settings,
    rng: np.random.Generator,
    *,
    n_candidates: int,
    n_jobs: int | None = 1,
    progress: bool | None = None,
) -> tuple[NullGain, NullDraws] | None:
    """The null gain of the ladder's first rung, whose margin the paired test takes (None: no draws).

    Calibrated, the paired test reads the first rung alone.  The first rung is the best of
    ``n_candidates``, so its bound's level carries the ranking's Bonferroni factor.  The ladder's
    end is not read: its later blocks were each chosen on the same held-out frames, and no level
    for that selection is at hand (on the benchmark, where the end was also calibrated, it
    decided 1 case of 65, naming a bending loss for a friction drift).

    Returns
    -------
    gain : NullGain
    draws : NullDraws
        The draws, on which another structure's null gain can be measured.
    """
    draws = NullDraws.simulate(family, splits, base, base_score.fits, settings, rng, n_jobs=n_jobs, progress=progress)
    if draws is None:
        return None
    first = run.chosen[0]
    level = 1.0 - settings.alpha / max(n_candidates, 1)
    return draws.gain((first,), base.with_blocks(blocks[first]), run.scores[0].fits, level), draws
