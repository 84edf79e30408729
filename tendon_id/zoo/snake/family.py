"""The snake chain family: every tendon set of a snake robot through its guides (:doc:`/guide/architecture`).

Its recording is :class:`~tendon_id.data.Recording`, its inputs
:class:`~tendon_id.zoo.inputs.TransmissionInputs`, its blocks those of
:mod:`tendon_id.zoo.blocks`, its models the zoo's :class:`~tendon_id.zoo.base.TransmissionModel`
s (the capstan models are the ones with a law: calibration, posterior and diagnosis); its fit is
:mod:`tendon_id.calibration.law`, its refit :mod:`~tendon_id.zoo.snake.refit`, its diagnosis parts
:mod:`~tendon_id.zoo.snake.diagnosis` and its posterior :mod:`tendon_id.calibration.law_posterior`.
"""

from __future__ import annotations

import numpy as np

from tendon_id.data import Recording
from tendon_id.errors import ConfigError
from tendon_id.family.protocol import Family
from tendon_id.zoo.blocks import BLOCKS
from tendon_id.zoo.capstan import CapstanModel
from tendon_id.zoo.inputs import TransmissionInputs
from tendon_id.zoo.registry import names_of
from tendon_id.zoo.snake import contract, diagnosis
from tendon_id.zoo.snake.refit import refit

__all__ = ["SNAKE", "SnakeFamily"]


class SnakeFamily(Family):
    """The snake chain (see the module docstring)."""

    name = "snake"
    title = "snake chain"
    recording = Recording
    blocks = BLOCKS
    predict_methods = ("predict", "predict_chain")

    def inputs(self, data, model=None) -> TransmissionInputs:
        if model is not None:
            return model.inputs(data)
        return data if isinstance(data, TransmissionInputs) else TransmissionInputs.from_recordings(data)

    # ---- blocks, fit and refit ---------------------------------------------------------------
    def check_base(self, model) -> None:
        if not isinstance(model, CapstanModel):
            name = getattr(model, "name", type(model).__name__)
            raise ConfigError(
                f"the diagnosis extends a capstan model with effect blocks; {name!r} is not one "
                f"(use {', '.join(self.law_models())}, or passage-capstan for a bench)",
                param="base",
            )

    def block_values(self, model, block) -> dict[str, float]:
        return model.block_values_.get(block.name, {})

    def start(self, model) -> tuple:
        return model.A_, model.B_, model.block_params_

    def merge(self, current, single) -> tuple:
        """The current rung's law and blocks, with the blocks that ``single`` adds at its fitted values."""
        values = dict(current.block_params_)
        if single is not None:
            values.update({k: v for k, v in single.block_params_.items() if k not in values})
        return current.A_, current.B_, values

    def refit(self, structure, inputs, start, max_nfev, tol=None):
        return refit(structure, inputs, *start, max_nfev=max_nfev, tol=tol)

    def residual(self, model, inputs):
        """Measured minus predicted terminal reading [N], shape (T, n), NaN in the model's warm-up."""
        e = inputs.terminal - model.terminal_reading(inputs, *self.start(model))
        e[inputs.since_start < float(model.warmup_s)] = np.nan
        return e

    # ---- diagnosis -----------------------------------------------------------------------------
    def splits(self, train, test, folds, base):
        return diagnosis.make_splits(train, test, base.geometry_, folds)

    def candidates(self, base, inputs, effects):
        """Each effect's block, placed where the base's residual on ``inputs`` says (a worn guide: which one)."""
        start = self.start(base)
        resid = inputs.terminal - base.terminal_reading(inputs, *start)
        return {e: self.blocks[e].localise(base, inputs, *start, resid) for e in effects}

    def strata(self, inputs):
        return diagnosis.strata_masks(inputs)

    def signatures(self, structure, fitted, inputs, blocks):
        return diagnosis.signatures(structure, fitted, inputs, blocks)

    def noise_floor(self, split, model, inputs, residual, rng, settings):
        return diagnosis.noise_floor(
            split.noise, model, inputs, residual, rng, draws=settings.floor_draws, level=1 - settings.alpha
        )

    def simulate_null(self, split, model, rng, draws=1):
        return diagnosis.simulate_null(split.noise, model, split, rng, draws)

    # ---- posterior and reports ---------------------------------------------------------------
    def likelihood(self, model, data, **options):
        # emcee and ArviZ load here, not with the family: reading a file or asking --help needs neither.
        from tendon_id.calibration.law_posterior import law_likelihood

        if not isinstance(model, CapstanModel):
            raise ConfigError(f"the posterior is defined for the capstan models ({', '.join(self.law_models())})")
        return law_likelihood(model, data, **options)

    def law_models(self) -> list[str]:
        return names_of(CapstanModel)

    def calibration_doc(self, model, recordings) -> dict:
        """``{"model", "tying", "A", "B", "mu0", "terminal": M, ..., "alpha_0", "alpha_c"}``.

        ``A``, ``B``, ``mu0``: tied, n numbers each (one per tendon), per-guide, N-1 lists of n.  ``alpha_0`` is the
        fitted routing wrap [rad], ``alpha_c`` the fitted clearance [rad] (None without contact).
        """

        def shape(a: np.ndarray):
            return a[0].tolist() if model.tying == "tied" else a.tolist()

        return {
            "model": model.name,
            "tying": model.tying,
            "A": shape(model.A_),
            "B": shape(model.B_),
            "mu0": shape(model.mu0_),
            "terminal": model.score(recordings)["terminal"],
            "calibration": model.calibration_,
            "frames": int(sum(r.n_frames for r in recordings)),
            "alpha_0": model.alpha_0_,
            "alpha_c": model.alpha_c_,
        }

    def calibration_lines(self, model, doc) -> list[str]:
        """The fitted geometry, which a user could not have given: the routing wrap and the clearance."""
        clearance = "" if doc["alpha_c"] is None else f", clearance alpha_c = {doc['alpha_c']:.4f} rad"
        return [f"fitted geometry: routing wrap alpha_0 = {doc['alpha_0']:.4f} rad{clearance}"]

    def calibration_figures(self, doc) -> dict:
        """The terminal RMSE [N] and the loss, the mean squared log error of the terminal reading [-]."""
        return {"rmse": doc["terminal"]["rmse"], "unit": "N", "loss": doc["calibration"]["loss"]}

    def score_lines(self, model, score, recording, name) -> list[str]:
        t = score["terminal"]
        lines = [
            f"{model.name} on {name} ({recording.n_frames} frames)",
            f"terminal joint     RMSE {t['rmse']:8.3f} N   R2 {t['r2']:7.3f}   max error {t['max_error']:8.3f} N",
        ]
        if score["joints"]:
            for j, mj in enumerate(score["joints"]["per_joint"], start=1):
                lines.append(
                    f"joint {j:2d}           RMSE {mj['rmse']:8.3f} N   R2 {mj['r2']:7.3f}   "
                    f"max error {mj['max_error']:8.3f} N"
                )
            o = score["joints"]["overall"]
            if o:
                lines.append(f"intermediate 2..{recording.n_modules - 1}  RMSE {o['rmse']:8.3f} N   R2 {o['r2']:7.3f}")
        return lines

    # ---- contract ----------------------------------------------------------------------------
    def check_predictions(self, model, test):
        return contract.check_shapes(model, test)

    def check_labels_only(self, model, train, test, pred, seed):
        contract.check_terminal_only(model, train, test, pred, seed)

    def foreign_data(self, test):
        return contract.shorter_robot(test)


#: The snake chain family (registered as ``"snake"``).
SNAKE = SnakeFamily()
