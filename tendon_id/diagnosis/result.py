"""What a diagnosis returns: one result object, and its JSON form (the ``--json`` floor of :doc:`/guide/diagnosis`).

Errors are in the unit of the base's family (:attr:`DiagnosisResult.unit`: N, or N m for a
torque passage), written [unit] below.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tendon_id.diagnosis.moments import nan_mean_square
from tendon_id.diagnosis.where import Stratum

VERDICT_KINDS = ("none", "explained", "partial", "family", "unexplained")


@dataclass(frozen=True)
class CandidateResult:
    """One candidate effect added to the base and refitted.

    Attributes
    ----------
    effect : str
        The effect's name among its family's blocks (a snake's: :doc:`/guide/simulator`).
    block : dict
        The block as saved (``Block.to_dict``), with its fitted parameters.
    heldout_rmse : float
        Held-out RMSE of base plus this block [unit].
    gap_closed : float
        Share of the base's held-out mean squared error above the noise floor that it removes [-].
    improvement_ci : tuple of float
        Bootstrap interval of the drop in mean squared error [unit^2].
    significant : bool
        The interval excludes 0 (at the Bonferroni-corrected level).
    ic_delta : float
        Change of the training BIC against the base (negative: better).
    params : dict
        Fitted block parameters.
    location : str
        Where the effect sits, for localised blocks (e.g. "guides 4, 8").
    confounded : list of str
        Block parameters strongly correlated with the law.
    at_bound : tuple of str
        Parameters fitted onto the far edge of their plausible range: the block is strained to
        mimic something else, so the verdict does not name it.
    """

    effect: str
    block: dict
    heldout_rmse: float
    gap_closed: float
    improvement_ci: tuple[float, float]
    significant: bool
    ic_delta: float
    params: dict
    location: str = ""
    confounded: tuple = ()
    at_bound: tuple = ()

    def to_dict(self) -> dict:
        return {
            "effect": self.effect,
            "heldout_rmse": self.heldout_rmse,
            "gap_closed": self.gap_closed,
            "ic_delta": self.ic_delta,
            "params": self.params,
            "significant": self.significant,
            "improvement_ci": list(self.improvement_ci),
            "location": self.location,
            "confounded": list(self.confounded),
            "at_bound": list(self.at_bound),
            "block": self.block,
        }


@dataclass(frozen=True)
class Rung:
    """One rung of the ladder: the base plus ``effects``.

    Attributes
    ----------
    effects : list of str
    heldout_rmse : float [unit]
    gap_closed : float [-]
    improvement_ci : tuple of float
        Drop in mean squared error against the rung below [unit^2] (NaN for the base).
    """

    effects: list
    heldout_rmse: float
    gap_closed: float
    improvement_ci: tuple[float, float] = (float("nan"), float("nan"))

    def to_dict(self) -> dict:
        return {
            "effects": list(self.effects),
            "heldout_rmse": self.heldout_rmse,
            "gap_closed": self.gap_closed,
            "improvement_ci": list(self.improvement_ci),
        }


@dataclass(frozen=True)
class Verdict:
    """``kind`` is one of :data:`VERDICT_KINDS`; ``remaining`` the share of the gap left [-]; ``rivals`` the
    candidates that alone close nearly as much of it as the effect named first (these data hardly tell them apart)."""

    kind: str
    effects: list
    remaining: float
    text: str
    rivals: list = field(default_factory=list)

    @property
    def label(self) -> str:
        """The effect named first, or the kind when none is named (the benchmark's confusion label)."""
        return self.effects[0] if self.kind in ("explained", "partial", "family") and self.effects else self.kind

    def to_dict(self) -> dict:
        return {
            "kind": self.kind,
            "effects": list(self.effects),
            "remaining": self.remaining,
            "text": self.text,
            "rivals": list(self.rivals),
        }


@dataclass
class DiagnosisResult:
    """Everything :func:`~tendon_id.diagnosis.diagnose` found.

    Attributes
    ----------
    base : str
        The base model's zoo name.
    base_rmse, noise_floor : float
        Held-out RMSE of the (refitted) base, and of a perfect model [unit].
    noise_floor_upper : float
        The ``1 - alpha`` quantile of a perfect model's RMSE over simulated sensor draws [unit].
    noise_source : str
    validation : str
        ``"test"`` or the cross-validation used.
    where : list of Stratum
    whiteness : dict
        Ljung–Box p-values of the base's held-out residual, per tendon.
    cross_correlation : dict
        Correlation of that residual with each signature column.
    candidates : list of CandidateResult
        Ranked best first.
    skipped : dict
        Candidates not tried, with the reason (already in the base).
    vote, vote_shares, vote_agrees :
        The sparse regression's vote and whether it names the top-ranked candidate.
    ladder : list of Rung
        The base, then each accepted effect.
    verdict : Verdict
    warnings : list of str
    model : Estimator
        The last rung's model, refitted on all the training data.
    plots : dict
        Held-out residual and leading signature columns (subsampled) for the report.
    seconds : float
    unit : str
        Unit of the errors: ``N``, or ``N m`` for a torque passage.
    truth : dict or None
        On simulated data, what the simulator put in (``recipe``, ``effects``, ``friction_truth``,
        ``session``), so the report can set the finding beside it; None for real data.
    null_gains : list of NullGain
        Where the floor alone showed no gap, what the ladder's first rung gains on data
        simulated from the base (:mod:`~tendon_id.diagnosis.calibrate`); empty elsewhere.
    null_draws : NullDraws or None
        Those draws, on which another structure's null gain can be measured (not saved).
    """

    base: str
    base_rmse: float
    noise_floor: float
    noise_floor_upper: float
    noise_source: str
    validation: str
    n_train: int
    n_heldout: int
    where: list
    whiteness: dict
    cross_correlation: dict
    candidates: list
    skipped: dict
    vote: str | None
    vote_shares: dict
    vote_agrees: bool
    ladder: list
    verdict: Verdict
    warnings: list = field(default_factory=list)
    model: object = None
    plots: dict = field(default_factory=dict, repr=False)
    seconds: float = 0.0
    unit: str = "N"
    truth: dict | None = None
    null_gains: list = field(default_factory=list)
    null_draws: object = field(default=None, repr=False)

    @classmethod
    def assemble(cls, *, residual, floor, library, ranked: list, rng, heldout_frames: int, **fields) -> DiagnosisResult:
        """The result from the base's held-out ``residual`` [unit], the noise ``floor``, signatures and ranking.

        Computes what every family reports alike: the whiteness of the residual, its
        correlation with the signatures, the sparse vote, the plots and the warnings of
        candidates fitted onto a bound; ``fields`` are the rest (``base``, ``validation``,
        ``n_train``, ``where``, ``skipped``, ``ladder``, ``verdict``, ``warnings``, ``model``,
        ``seconds``, ``unit``).
        """
        from tendon_id.diagnosis.stats import ljung_box_p

        vote, shares = library.sparse_vote(residual)
        warnings = list(fields.pop("warnings", []))
        warnings += [f"{c.effect}: {q}" for c in ranked for q in c.confounded]
        warnings += [
            f"{c.effect}: {', '.join(c.at_bound)} reached the edge of its plausible range; the effect it stands in "
            "for may be outside the library"
            for c in ranked
            if c.at_bound
        ]
        return cls(
            base_rmse=float(np.sqrt(nan_mean_square(residual))),
            noise_floor=floor.rmse,
            noise_floor_upper=floor.upper,
            noise_source=floor.source,
            n_heldout=int(heldout_frames),
            whiteness={"ljung_box_p": ljung_box_p(residual), "lags": 10},
            cross_correlation=library.correlations(residual),
            candidates=ranked,
            vote=vote,
            vote_shares=shares,
            vote_agrees=bool(ranked) and vote == ranked[0].effect,
            warnings=warnings,
            plots=library.plot_data(residual, [c.effect for c in ranked[:3]], rng),
            **fields,
        )

    def to_dict(self) -> dict:
        """The JSON form: ``base``, ``gap``, ``where``, ``candidates``, ``ladder``, ``verdict`` and more."""
        return {
            "base": self.base,
            "gap": {
                "base_rmse": self.base_rmse,
                "noise_floor": self.noise_floor,
                "noise_floor_upper": self.noise_floor_upper,
                "noise_source": self.noise_source,
            },
            "where": [s.to_dict() for s in self.where],
            "candidates": [c.to_dict() for c in self.candidates],
            "ladder": [r.to_dict() for r in self.ladder],
            "verdict": self.verdict.to_dict(),
            "validation": self.validation,
            "frames": {"train": self.n_train, "heldout": self.n_heldout},
            "whiteness": self.whiteness,
            "cross_correlation": self.cross_correlation,
            "sparse_vote": {"effect": self.vote, "shares": self.vote_shares, "agrees": self.vote_agrees},
            "skipped": self.skipped,
            "warnings": list(self.warnings),
            "seconds": self.seconds,
            "unit": self.unit,
            "truth": self.truth,
            "null_gains": [g.to_dict() for g in self.null_gains],
        }

    def top_strata(self, n: int = 5) -> list[Stratum]:
        """The strata where the error is most concentrated (share of error over share of frames)."""
        rows = [s for s in self.where if s.share_frames > 0]
        return sorted(rows, key=lambda s: -np.nan_to_num(s.concentration))[:n]

    def summary(self) -> str:
        """A few lines for a terminal."""
        u = self.unit
        lines = [
            f"base {self.base}: held-out RMSE {self.base_rmse:.3g} {u}, noise floor {self.noise_floor:.3g} {u} "
            f"(up to {self.noise_floor_upper:.3g} {u}; {self.validation})",
            f"verdict: {self.verdict.text}",
        ]
        for r in self.ladder:
            lines.append(f"  {' + '.join(r.effects):40s} {r.heldout_rmse:8.3g} {u}  gap closed {r.gap_closed:6.1%}")
        if self.candidates:
            lines.append("candidates (best first):")
            for c in self.candidates:
                star = "*" if c.significant else " "
                loc = f" [{c.location}]" if c.location else ""
                lines.append(f"  {star} {c.effect:18s}{loc} {c.heldout_rmse:8.3g} {u}  gap closed {c.gap_closed:6.1%}")
        for g in self.null_gains:
            lines.append(
                f"paired margin of {' + '.join(g.effects)}: {g.margin:.1%} (its refit lowered the base's mean squared "
                f"error by {np.expm1(np.mean(g.log_ratios)):.1%} on average over {len(g.log_ratios)} draws of data "
                "simulated from the base)"
            )
        for w in self.warnings:
            lines.append(f"warning: {w}")
        return "\n".join(lines)
