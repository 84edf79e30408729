"""The prior guard: is a learned cascade better than the calibrated physics it was built on?

A physics-guided cascade starts from a calibrated capstan model (its prior, paper Eq. (9)).
Where the data are out of the learner's reach (stick/slip it cannot see, too few
trajectories), the learned model can end up worse than that prior, and nothing else would
tell the user.  After fitting, :class:`GuardedCascade` scores both on the validation
trajectories, stores the two figures (:attr:`GuardedCascade.guard_`), warns when the
cascade is worse (:class:`PriorGuardWarning`) and, with ``fallback=True``, predicts with the
prior instead.  The default keeps the cascade, as the paper does.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from contextlib import contextmanager

import numpy as np

from tendon_id.data import Recording
from tendon_id.metrics import tendon_metrics
from tendon_id.zoo.base import TransmissionModel
from tendon_id.zoo.registry import model_class

#: Prefix of the prior model's arrays inside the cascade's ``arrays.npz``.
PRIOR_ARRAYS = "prior/"


class PriorGuardWarning(UserWarning):
    """A learned cascade predicts the validation trajectories worse than its own calibrated prior."""


@contextmanager
def quiet_guard():
    """A context in which :class:`PriorGuardWarning` is not shown: for callers that report ``guard_`` themselves."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PriorGuardWarning)
        yield


def guard_report(cascade_rmse: float, prior_rmse: float, prior: str, frames: int, fallback: bool) -> dict:
    """The guard's figures as stored in a fitted model (``guard_``) and its JSON.

    Parameters
    ----------
    cascade_rmse, prior_rmse : float
        Terminal RMSE on the validation trajectories [N] (:doc:`/guide/zoo`, mean over tendons).
    prior : str
        The prior model's zoo name.
    frames : int
        Validation frames scored.
    fallback : bool
        Whether the model now predicts with its prior.
    """
    return {
        "cascade_rmse": float(cascade_rmse),
        "prior_rmse": float(prior_rmse),
        "ratio": float(cascade_rmse / prior_rmse) if prior_rmse > 0 else float("inf"),
        "worse": not cascade_rmse <= prior_rmse,  # a NaN prediction counts as worse
        "prior": prior,
        "frames": int(frames),
        "fallback": bool(fallback),
    }


def guard_message(model: str, guard: dict) -> str:
    """One or two plain lines: the two validation figures, and what to do when the cascade is worse."""
    line = (
        f"{model}: validation terminal RMSE {guard['cascade_rmse']:.3g} N against {guard['prior_rmse']:.3g} N "
        f"for its calibrated prior {guard['prior']} ({guard['ratio']:.2f}x, {guard['frames']} frames)"
    )
    if not guard["worse"]:
        return line
    if guard["fallback"]:
        return line + f"\nWARNING: the learned cascade is worse than its prior; it predicts with {guard['prior']}."
    return (
        line + f"\nWARNING: the learned cascade is worse than its prior {guard['prior']} on held-out trajectories; "
        f"use {guard['prior']} instead, or refit with fallback=True (--set fallback=true)."
    )


class GuardedCascade(TransmissionModel):
    """What a learned cascade with a calibrated prior model shares: the guard and the fallback.

    A subclass sets ``self.prior_model_`` (a fitted capstan model) in ``fit``, then calls
    :meth:`_guard` with its validation trajectories, and routes ``predict_chain`` through
    :meth:`_prior_chain` first.  Its ``fallback`` setting says what to do when the cascade
    is worse.

    Attributes
    ----------
    prior_model_ : TransmissionModel
        The calibrated prior model.
    guard_ : dict
        :func:`guard_report`'s figures (empty for a model saved before the guard existed).
    """

    def _guard(self, val: Recording | Sequence[Recording]) -> dict:
        """Score the cascade and its prior on ``val``, store ``guard_``, and warn when the cascade is worse."""
        self.guard_ = {}  # scored as the cascade itself
        labels = np.concatenate([r.terminal for r in ([val] if isinstance(val, Recording) else val)])
        cascade = tendon_metrics(self.predict_terminal(val), labels)["rmse"]
        prior = tendon_metrics(self.prior_model_.predict_terminal(val), labels)["rmse"]
        worse = not cascade <= prior
        self.guard_ = guard_report(cascade, prior, self.prior_model_.name, len(labels), worse and bool(self.fallback))
        if worse:
            warnings.warn(guard_message(self.name, self.guard_), PriorGuardWarning, stacklevel=3)
        return self.guard_

    @property
    def uses_prior_(self) -> bool:
        """True when the guard found the cascade worse and ``fallback`` sends predictions to the prior."""
        return bool(getattr(self, "guard_", {}).get("fallback"))

    def _prior_chain(self, data) -> np.ndarray | None:
        """The prior's chain when the model falls back to it, else None."""
        return self.prior_model_.predict_chain(data) if self.uses_prior_ else None

    def predict_terminal(self, data) -> np.ndarray:
        if self.uses_prior_:
            return self.prior_model_.predict_terminal(data)
        return super().predict_terminal(data)

    # ---- persistence of the prior model inside the cascade's files ----------------------
    def _prior_state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """``({"prior_model": ..., "guard": ...}, arrays)`` to merge into the subclass's state."""
        state, arrays = self.prior_model_._state()
        doc = {"model": self.prior_model_.name, "params": self.prior_model_._json_params(), "state": state}
        return {"prior_model": doc, "guard": self.guard_}, {PRIOR_ARRAYS + k: v for k, v in arrays.items()}

    def _restore_prior(self, state: dict, arrays: dict[str, np.ndarray]) -> None:
        self.guard_ = dict(state.get("guard") or {})
        self.prior_model_ = None
        doc = state.get("prior_model")
        if doc is None:  # saved before the guard existed
            return
        mine = {k[len(PRIOR_ARRAYS) :]: v for k, v in arrays.items() if k.startswith(PRIOR_ARRAYS)}
        self.prior_model_ = model_class(doc["model"]).from_saved(doc["params"], doc["state"], mine)
