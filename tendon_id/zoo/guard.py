"""The prior guard: is a learned cascade better than the calibrated physics it was built on?

A physics-guided cascade starts from a calibrated capstan model (its prior, paper Eq. (9)).
Where the data are out of the learner's reach (stick/slip it cannot see, too few
trajectories), the learned model can end up worse than that prior, and nothing else would
tell the user.  After fitting, :class:`GuardedCascade` scores both on the validation
trajectories, stores the figures (:attr:`GuardedCascade.guard_`), warns when the cascade is
worse (:class:`PriorGuardWarning`) and, with ``fallback``, predicts with the prior instead.
The default keeps the cascade, as the paper does.

The pool of validation trajectories can hide a kind of motion on which the correction hurts:
better on many steps, worse on a few paths, better overall.  So the guard also scores each
kind of motion on its own (steps, scans, paths; :mod:`tendon_id.zoo.motion_kind`, read from
the joint angles), warns when any kind is worse, and with ``fallback="per-kind"`` predicts the
trajectories of such a kind with the prior.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from contextlib import contextmanager

import numpy as np

from tendon_id.data import Recording
from tendon_id.errors import ConfigError
from tendon_id.metrics import tendon_metrics
from tendon_id.zoo.base import TransmissionModel
from tendon_id.zoo.inputs import as_recordings
from tendon_id.zoo.motion_kind import KINDS, RULES, MotionKindRules, TrajectoryKind, frame_kinds, trajectory_kinds
from tendon_id.zoo.registry import model_class

#: Prefix of the prior model's arrays inside the cascade's ``arrays.npz``.
PRIOR_ARRAYS = "prior/"

#: The ``fallback`` settings: keep the cascade; the prior everywhere when the pool is worse;
#: that, or else the prior on the kinds of motion that are worse.
FALLBACKS = (False, True, "per-kind")


class PriorGuardWarning(UserWarning):
    """A learned cascade predicts the validation trajectories, or one kind of them, worse than its calibrated prior."""


@contextmanager
def quiet_guard():
    """A context in which :class:`PriorGuardWarning` is not shown: for callers that report ``guard_`` themselves."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PriorGuardWarning)
        yield


def check_fallback(value) -> bool | str:
    """``value`` as one of :data:`FALLBACKS`, else a ConfigError that lists them."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if value == "per-kind":
        return value
    raise ConfigError(f"unknown fallback {value!r}; known: false, true, 'per-kind'", param="fallback")


def _figures(cascade_rmse: float, prior_rmse: float, frames: int) -> dict:
    return {
        "cascade_rmse": float(cascade_rmse),
        "prior_rmse": float(prior_rmse),
        "ratio": float(cascade_rmse / prior_rmse) if prior_rmse > 0 else float("inf"),
        "worse": not cascade_rmse <= prior_rmse,  # a NaN prediction counts as worse
        "frames": int(frames),
    }


def guard_report(
    cascade_rmse: float,
    prior_rmse: float,
    prior: str,
    frames: int,
    fallback: bool,
    *,
    kinds: dict | None = None,
    fallback_kinds: Sequence[str] = (),
) -> dict:
    """The guard's figures as stored in a fitted model (``guard_``) and its JSON.

    Parameters
    ----------
    cascade_rmse, prior_rmse : float
        Terminal RMSE on the pooled validation trajectories [N] (:doc:`/guide/zoo`, mean over tendons).
    prior : str
        The prior model's zoo name.
    frames : int
        Validation frames scored.
    fallback : bool
        Whether the model now predicts with its prior everywhere.
    kinds : dict, optional
        :func:`kind_breakdown`'s figures per kind of motion.
    fallback_kinds : sequence of str
        The kinds whose trajectories the model predicts with its prior (``fallback="per-kind"``).

    Returns
    -------
    dict
        ``cascade_rmse``, ``prior_rmse`` [N], ``ratio`` [-], ``worse``, ``prior``, ``frames``,
        ``fallback`` (as before the breakdown), ``kinds`` and ``fallback_kinds``.
    """
    return {
        **_figures(cascade_rmse, prior_rmse, frames),
        "prior": prior,
        "fallback": bool(fallback),
        "kinds": dict(kinds or {}),
        "fallback_kinds": list(fallback_kinds),
    }


def kind_breakdown(
    cascade: np.ndarray, prior: np.ndarray, labels: np.ndarray, trajectories: Sequence[TrajectoryKind]
) -> dict:
    """The guard's figures for each kind of motion present.

    Parameters
    ----------
    cascade, prior, labels : ndarray, shape (T, n)
        Terminal predictions of the cascade and of its prior, and the labels [N], ``n`` tendons per set.
    trajectories : sequence of TrajectoryKind
        Every trajectory's kind and frames (:func:`~tendon_id.zoo.motion_kind.trajectory_kinds`).

    Returns
    -------
    dict
        ``{kind: {"cascade_rmse", "prior_rmse", "ratio", "worse", "frames", "trajectories"}}``
        in :data:`~tendon_id.zoo.motion_kind.KINDS` order; RMSE over the kind's frames pooled.
    """
    out = {}
    for kind in KINDS:
        mine = [t for t in trajectories if t.kind == kind]
        if not mine:
            continue
        rows = np.concatenate([np.arange(t.start, t.stop) for t in mine])
        c = tendon_metrics(cascade[rows], labels[rows])["rmse"]
        p = tendon_metrics(prior[rows], labels[rows])["rmse"]
        out[kind] = {**_figures(c, p, len(rows)), "trajectories": len(mine)}
    return out


def worse_kinds(guard: dict) -> dict[str, float]:
    """``{kind: ratio}`` of the kinds of motion on which the cascade was worse than its prior (older guards: none)."""
    return {k: g["ratio"] for k, g in (guard.get("kinds") or {}).items() if g["worse"]}


def worse_kinds_text(guard: dict) -> str:
    """The worse kinds with their ratios, e.g. ``"steps 1.04x, scans 1.10x"`` (empty when none)."""
    return ", ".join(f"{k} {r:.2f}x" for k, r in worse_kinds(guard).items())


def guard_fired(guard: dict) -> bool:
    """Whether the cascade was worse than its prior on validation, pooled or on one kind of motion."""
    return bool(guard.get("worse")) or bool(worse_kinds(guard))


def guard_message(model: str, guard: dict) -> str:
    """Plain lines: the validation figures (pooled, then per kind), and what to do when the cascade is worse."""
    kinds = guard.get("kinds") or {}
    per_kind = "; " + ", ".join(f"{k} {g['ratio']:.2f}x on {g['frames']}" for k, g in kinds.items()) if kinds else ""
    line = (
        f"{model}: validation terminal RMSE {guard['cascade_rmse']:.3g} N against {guard['prior_rmse']:.3g} N "
        f"for its calibrated prior {guard['prior']} ({guard['ratio']:.2f}x, {guard['frames']} frames{per_kind})"
    )
    bad = worse_kinds(guard)
    named = ", ".join(f"{k} {r:.2f}x" for k, r in bad.items())
    prior = guard["prior"]
    if guard["worse"]:
        if guard["fallback"]:
            return line + f"\nWARNING: the learned cascade is worse than its prior; it predicts with {prior}."
        where = f" ({named})" if bad else ""
        return (
            line + f"\nWARNING: the learned cascade is worse than its prior {prior} on held-out trajectories{where}; "
            f"use {prior} instead, or refit with fallback=True (--set fallback=true)."
        )
    if not bad:
        return line
    if guard.get("fallback_kinds"):
        fell = " and ".join(guard["fallback_kinds"])
        return line + (
            f"\nWARNING: the learned cascade is worse than its prior {prior} on some kinds of motion ({named}); "
            f"it predicts {fell} trajectories with {prior}."
        )
    return line + (
        f"\nWARNING: the learned cascade is worse than its prior {prior} on some kinds of motion ({named}), though "
        f"better on their pool; use {prior} for such motion, or refit with fallback='per-kind' "
        "(--set fallback=per-kind)."
    )


class GuardedCascade(TransmissionModel):
    """What a learned cascade with a calibrated prior model shares: the guard and the fallback.

    A subclass sets ``self.prior_model_`` (a fitted capstan model) in ``fit``, then calls
    :meth:`_guard` with its validation trajectories; ``predict_chain`` returns
    :meth:`_prior_chain` when that is not None, and passes its own chain through
    :meth:`_prior_where_worse`.  Its ``fallback`` setting (:data:`FALLBACKS`) says what to do
    when the cascade is worse: ``False`` keeps it; ``True`` predicts with the prior everywhere
    when the pooled validation is worse; ``"per-kind"`` does that too, and else predicts with
    the prior the trajectories of each kind of motion that validated worse (each trajectory's
    kind read from its joint angles at prediction, :mod:`tendon_id.zoo.motion_kind`).

    Attributes
    ----------
    prior_model_ : TransmissionModel
        The calibrated prior model.
    guard_ : dict
        :func:`guard_report`'s figures (empty for a model saved before the guard existed).
    kind_rules_ : MotionKindRules
        The thresholds the validation trajectories were classified with, and prediction's are.
    """

    def check_settings(self) -> None:
        """Raise ConfigError for an unknown ``fallback``, before any training."""
        check_fallback(self.fallback)

    def _guard(self, val: Recording | Sequence[Recording]) -> dict:
        """Score the cascade and its prior on ``val``, pooled and per kind of motion; store ``guard_``; warn."""
        mode = check_fallback(self.fallback)
        self.guard_ = {}  # scored as the cascade itself
        self.kind_rules_ = RULES
        recs = as_recordings(val)
        labels = np.concatenate([r.terminal for r in recs])
        cascade = self.predict_terminal(recs)
        prior = self.prior_model_.predict_terminal(recs)
        pooled = _figures(tendon_metrics(cascade, labels)["rmse"], tendon_metrics(prior, labels)["rmse"], len(labels))
        kinds = kind_breakdown(cascade, prior, labels, trajectory_kinds(recs, self.kind_rules_))
        everywhere = pooled["worse"] and mode is not False
        # per kind only where the pool passes: a pool that fails already sends everything to the prior
        fall_kinds = [k for k, g in kinds.items() if g["worse"]] if mode == "per-kind" and not everywhere else []
        self.guard_ = guard_report(
            pooled["cascade_rmse"],
            pooled["prior_rmse"],
            self.prior_model_.name,
            pooled["frames"],
            everywhere,
            kinds=kinds,
            fallback_kinds=fall_kinds,
        )
        if guard_fired(self.guard_):
            warnings.warn(guard_message(self.name, self.guard_), PriorGuardWarning, stacklevel=3)
        return self.guard_

    @property
    def uses_prior_(self) -> bool:
        """True when the pool validated worse and ``fallback`` sends every prediction to the prior."""
        return bool(getattr(self, "guard_", {}).get("fallback"))

    @property
    def prior_kinds_(self) -> tuple[str, ...]:
        """The kinds of motion whose trajectories the model predicts with its prior (``fallback="per-kind"``)."""
        return tuple(getattr(self, "guard_", {}).get("fallback_kinds") or ())

    def _prior_chain(self, data) -> np.ndarray | None:
        """The prior's chain when the model falls back to it everywhere, else None."""
        return self.prior_model_.predict_chain(data) if self.uses_prior_ else None

    def _prior_frames(self, recs: list[Recording]) -> np.ndarray | None:
        """Frames (bool, shape (T,)) of the trajectories whose kind falls back to the prior; None when none."""
        if not self.prior_kinds_:
            return None
        mask = np.isin(frame_kinds(recs, getattr(self, "kind_rules_", RULES)), self.prior_kinds_)
        return mask if mask.any() else None

    def _prior_where_worse(self, recs: list[Recording], chain: np.ndarray) -> np.ndarray:
        """``chain`` (T, N, N, n) with the prior's on the trajectories of the kinds that fall back."""
        mask = self._prior_frames(recs)
        if mask is not None:
            chain[mask] = self.prior_model_.predict_chain(recs)[mask]
        return chain

    def _warn_stream_kinds(self) -> None:
        """A streamer sees a trajectory frame by frame, before its kind can be read: say it keeps the cascade."""
        if self.prior_kinds_ and not self.uses_prior_:
            warnings.warn(
                f"{self.name} streams its cascade on every kind of motion: a trajectory's kind is known only once "
                f"it has ended, so the prior it predicts {' and '.join(self.prior_kinds_)} trajectories with in "
                "batch is not used when streaming",
                PriorGuardWarning,
                stacklevel=3,
            )

    def predict_terminal(self, data) -> np.ndarray:
        if self.uses_prior_:
            return self.prior_model_.predict_terminal(data)
        out = super().predict_terminal(data)
        if self.prior_kinds_:  # the prior's own reading, should it model the load cell beyond the chain
            recs = as_recordings(data)
            mask = self._prior_frames(recs)
            if mask is not None:
                out[mask] = self.prior_model_.predict_terminal(recs)[mask]
        return out

    # ---- persistence of the prior model inside the cascade's files ----------------------
    def _prior_state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """``({"prior_model": ..., "guard": ..., "motion_kind_rules": ...}, arrays)`` for the subclass's state."""
        state, arrays = self.prior_model_._state()
        doc = {"model": self.prior_model_.name, "params": self.prior_model_._json_params(), "state": state}
        rules = getattr(self, "kind_rules_", RULES).to_dict()
        return (
            {"prior_model": doc, "guard": self.guard_, "motion_kind_rules": rules},
            {PRIOR_ARRAYS + k: v for k, v in arrays.items()},
        )

    def _restore_prior(self, state: dict, arrays: dict[str, np.ndarray]) -> None:
        self.guard_ = dict(state.get("guard") or {})
        self.kind_rules_ = MotionKindRules.from_dict(state.get("motion_kind_rules"))  # default: saved before kinds
        self.prior_model_ = None
        doc = state.get("prior_model")
        if doc is None:  # saved before the guard existed
            return
        mine = {k[len(PRIOR_ARRAYS) :]: v for k, v in arrays.items() if k.startswith(PRIOR_ARRAYS)}
        self.prior_model_ = model_class(doc["model"]).from_saved(doc["params"], doc["state"], mine)
