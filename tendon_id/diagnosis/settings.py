"""Settings of a diagnosis: one frozen, validated dataclass (like sbi's configs)."""

from __future__ import annotations

from dataclasses import dataclass

from tendon_id.errors import ConfigError


@dataclass(frozen=True)
class DiagnosisSettings:
    """How :func:`~tendon_id.diagnosis.diagnose` decides.

    Parameters
    ----------
    folds : int
        Blocked cross-validation folds (by trajectory for the snake chain, by file for a bench)
        when no test data is given.
    alpha : float
        Significance level of the improvement tests; the first rung's is divided by the
        number of candidates (Bonferroni), since the best of them is picked.
    n_boot : int
        Bootstrap resamples.
    block_s : float
        Block length of the moving-block bootstrap [s] (Künsch 1989): held-out residuals of
        a model that misses slow physics are correlated over seconds, and blocks this long
        keep that correlation in every resample.
    min_excess : float
        No gap is reported when the base's held-out mean squared error exceeds the upper
        quantile (at ``1 - alpha``) of a perfect model's by less than this share of it [-]
        (:meth:`~tendon_id.family.Family.noise_floor`), unless a candidate lowers it
        significantly by at least this share on the same frames
        (:func:`~tendon_id.diagnosis.verdict.shows_gap`: the ladder's first rung or its end).
        That paired margin is calibrated instead where the family simulates its sensors
        (``null_draws``).
        A practical margin: the simulated sensors are an estimate (their clean signals are
        smoothed readings), a free parameter absorbs some of what noisy inputs cost, and a gap
        of a tenth of the floor's RMSE is not worth a new block.
    min_excess_structural : float
        The paired test's margin for a candidate without free parameters (a contact gate,
        per-tendon wraps) [-]: it cannot absorb what noisy inputs cost, so by default any
        significant improvement on the same frames shows a gap (on the 20 null cases of the
        benchmark, per-tendon wraps lowered the held-out error by 4 % at most, never
        significantly).
    floor_draws : int
        Simulated measurement draws of the noise floor.
    null_draws : int
        Draws of data simulated from the base's fit that calibrate the paired test, where the
        floor alone shows no gap (:mod:`~tendon_id.diagnosis.calibrate`): the ladder's first rung
        must then gain more than its refit gains on those draws.  0 keeps the fixed margins
        ``min_excess`` and ``min_excess_structural`` (of the first rung and the ladder's end), as
        does a family that cannot simulate its sensors.
    null_tol : float
        Relative tolerance of the refits on the null draws [-], looser than a diagnosis's own
        (1e-5): on the benchmark's null seeds 5 and 12 a bending loss's log ratios moved by 0.001
        at most between 1e-5 and 1e-4, and the draws ran 1.6 to 1.9 times faster.
    null_scale : float
        Factor on the bound of a null gain's log ratio [-]: the simulated data's clean inputs
        are a running median, smoother than the truth's, and a block that absorbs input noise
        (a bending loss) gains less on them than on the real noise (on the benchmark's null
        seeds 5, 12 and 19, by a factor of 1.7, 1.25 and 1.0 in mean log ratio), so the bound
        is doubled.  On the 20 null cases, 1 gave 4 false alarms and 2 none
        (:doc:`/guide/diagnosis`).
    explained_share : float
        Share of the gap above the noise floor a ladder must close to call it explained [-].
    named_share : float
        Share it must close before any effect is named (below it: unexplained) [-].
    rival_share : float
        A candidate that alone closes at least ``named_share`` of the gap, and at most this share
        less than the effect named first, is reported as its rival: the data hardly tell them
        apart [-].
    ladder_width : int
        Candidates tried at each rung after the first: the best of the first ranking.
    max_rungs : int
        Effects a ladder may add.
    min_rung_gain : float, optional
        Share of the base's gap above the noise floor that a rung must close, besides being
        significant, to be accepted on the ladder [-]. Default: the family's
        (:attr:`~tendon_id.family.Family.min_rung_gain`: 0 for the snake chain, 0.01 for a
        bench passage, where a block whose parameter fits to its neutral value leaves the model
        as it was, and the refit's slack can still lower the held-out error by a consistent 1e-9
        of it: significant, but no effect).
    confound_corr : float
        Correlation between a new block's parameter and the law's above which they are
        reported as confounded [-].
    max_nfev : int
        Iterations of each refit (:meth:`~tendon_id.family.Family.refit`).
    seed : int
        Seed of the bootstrap.
    """

    folds: int = 3
    alpha: float = 0.05
    n_boot: int = 500
    block_s: float = 5.0
    min_excess: float = 0.25
    min_excess_structural: float = 0.0
    floor_draws: int = 20
    null_draws: int = 5
    null_tol: float = 1e-4
    null_scale: float = 2.0
    explained_share: float = 0.8
    named_share: float = 0.5
    rival_share: float = 0.1
    ladder_width: int = 3
    max_rungs: int = 4
    min_rung_gain: float | None = None
    confound_corr: float = 0.9
    max_nfev: int = 60
    seed: int = 0

    def __post_init__(self) -> None:
        checks = [
            (self.folds >= 2, "folds must be >= 2"),
            (0 < self.alpha < 1, "alpha must lie in (0, 1)"),
            (self.n_boot >= 50, "n_boot must be >= 50"),
            (self.block_s > 0, "block_s must be a positive time in s"),
            (self.min_excess >= 0 and self.min_excess_structural >= 0, "min_excess values must be >= 0"),
            (self.floor_draws >= 5, "floor_draws must be >= 5"),
            (self.null_draws == 0 or self.null_draws >= 3, "null_draws must be 0 (fixed margins) or >= 3"),
            (0 < self.null_tol < 0.1, "null_tol must lie in (0, 0.1)"),
            (self.null_scale >= 1, "null_scale must be >= 1 (the simulated null gains are a lower estimate)"),
            (0 < self.named_share <= self.explained_share <= 1, "need 0 < named_share <= explained_share <= 1"),
            (0 <= self.rival_share < 1, "rival_share must lie in [0, 1)"),
            (self.ladder_width >= 1 and self.max_rungs >= 1, "ladder_width and max_rungs must be >= 1"),
            (self.min_rung_gain is None or 0 <= self.min_rung_gain < 1, "min_rung_gain must lie in [0, 1)"),
            (0 < self.confound_corr <= 1, "confound_corr must lie in (0, 1]"),
            (self.max_nfev >= 5, "max_nfev must be >= 5"),
        ]
        for ok, msg in checks:
            if not ok:
                raise ConfigError(f"diagnosis settings: {msg}")
