"""The bench passage family: one tendon, or an antagonistic pair, over one passage on a bench.

See :doc:`/guide/architecture`.

Its recording is :class:`~tendon_id.data.passage.PassageRecording`, its inputs
:class:`~tendon_id.zoo.passage.inputs.PassageInputs`, its blocks those of
:mod:`tendon_id.zoo.passage.blocks` and :mod:`~tendon_id.zoo.passage.sensor_blocks`, its model
``passage-capstan``; its fit is :mod:`~tendon_id.zoo.passage.fitting`, its diagnosis parts
:mod:`~tendon_id.zoo.passage.diagnosis` and its posterior :mod:`~tendon_id.zoo.passage.likelihood`.
"""

from __future__ import annotations

import numpy as np

from tendon_id.data.passage import PassageRecording
from tendon_id.diagnosis.stats import difference_floor
from tendon_id.errors import ConfigError
from tendon_id.family.protocol import Family
from tendon_id.zoo.passage import diagnosis
from tendon_id.zoo.passage.blocks import BLOCKS
from tendon_id.zoo.passage.fitting import confounded_groups
from tendon_id.zoo.passage.inputs import PassageInputs

__all__ = ["PASSAGE", "PassageFamily"]


class PassageFamily(Family):
    """The bench passage (see the module docstring)."""

    name = "passage"
    title = "bench passage"
    recording = PassageRecording
    blocks = BLOCKS
    # A block whose parameter fits to its neutral value leaves the model as it was, and the
    # refit's slack can still lower the held-out error by a consistent 1e-9 of it.
    min_rung_gain = 0.01
    splits_read_the_fit = False  # by file, whatever the base

    def inputs(self, data, model=None) -> PassageInputs:
        if model is not None:
            return model.inputs(data)
        return data if isinstance(data, PassageInputs) else PassageInputs.from_recordings(data)

    def unit(self, inputs) -> str:
        return diagnosis.UNITS[inputs.quantity]

    # ---- blocks, fit and refit ---------------------------------------------------------------
    def check_base(self, model) -> None:
        if not callable(getattr(model, "with_blocks", None)):
            raise ConfigError(
                f"the diagnosis extends a model with effect blocks; {model.name!r} has none", param="base"
            )

    def block_values(self, model, block) -> dict[str, float]:
        return {p: model.theta_[f"{block.effect}:{p}"] for p in block.param_names}

    def start(self, model) -> dict:
        return model.theta_

    def merge(self, current, single) -> dict:
        theta = dict(current.theta_)
        if single is not None:
            theta.update({lab: v for lab, v in single.theta_.items() if ":" in lab and lab not in theta})
        return theta

    def refit(self, structure, inputs, start, max_nfev, tol=None):
        # nlopt's own stopping rule; a bench declares no sensors, so no null draws ask for another.
        return diagnosis.passage_refit(structure, inputs, start, max_nfev)

    def residual(self, model, inputs):
        return diagnosis.residual(model, inputs)

    # ---- diagnosis -----------------------------------------------------------------------------
    def splits(self, train, test, folds, base):
        return diagnosis.file_splits(train, test, folds)

    def strata(self, inputs):
        return diagnosis.passage_strata(inputs)

    def signatures(self, structure, fitted, inputs, blocks):
        return diagnosis.signatures(fitted, inputs, blocks)

    def noise_floor(self, split, model, inputs, residual, rng, settings):
        return difference_floor(residual)

    # ---- posterior and reports ---------------------------------------------------------------
    def likelihood(self, model, data, **options):
        # emcee and ArviZ load here, not with the family: reading a file or asking --help needs neither.
        from tendon_id.zoo.passage.likelihood import passage_likelihood

        return passage_likelihood(model, data, **options)

    def law_models(self) -> list[str]:
        return ["passage-capstan"]

    def calibration_doc(self, model, recordings) -> dict:
        """``{"model", "blocks", "direction", "quantity", "unit", "theta", "predicted": M, "correlation", ...}``."""
        inputs = self.inputs(recordings)
        return {
            "model": model.name,
            "blocks": list(model.blocks),
            "direction": model.direction,
            "side": model.side,
            "quantity": inputs.quantity,
            "unit": self.unit(inputs),
            "theta": model.theta_,
            "predicted": model.score(inputs)["predicted"],
            "calibration": model.calibration_,
            "correlation": model.calibration_.get("correlation"),
            "confounded": confounded_groups(list(model.theta_), model.calibration_.get("correlation")),
            "frames": int(inputs.output.shape[0]),
        }

    def calibration_lines(self, model, doc) -> list[str]:
        lines = [
            f"{model.name} {list(model.blocks)}: {model.side} RMSE {doc['predicted']['rmse']:.3g} {doc['unit']} "
            f"on {doc['frames']} frames"
        ]
        return lines + [
            f"the data pins a combination of {', '.join(group)}, not each (|correlation| > 0.99)"
            for group in doc["confounded"]
        ]

    def calibration_figures(self, doc) -> dict:
        """The predicted side's RMSE in its unit; the loss is its sum of squares, so no second number."""
        return {"rmse": doc["predicted"]["rmse"], "unit": doc["unit"], "loss": None}

    def score_lines(self, model, score, recording, name) -> list[str]:
        p = score["predicted"]
        unit = diagnosis.UNITS[recording.quantity]
        return [
            f"{model.name} on {name} ({recording.n_frames} frames), predicting the {score['side']} side",
            f"RMSE {p['rmse']:.4g} {unit}   R2 {p['r2']:.3f}   max error {p['max_error']:.4g} {unit}",
        ]

    # ---- contract ----------------------------------------------------------------------------
    def check_predictions(self, model, test):
        pred = model.predict(test)
        assert pred.shape == (test.n_frames,), f"{model.name}: predict shape {pred.shape}, expected {(test.n_frames,)}"
        return pred

    def foreign_data(self, test):
        """The same frames as a passage of the other quantity (a torque model must refuse a tension passage)."""
        other = "tension" if test.quantity == "torque" else "torque"
        frame = test.frame.assign(input=np.abs(test.frame["input"]) + 1.0, output=np.abs(test.frame["output"]) + 1.0)
        return PassageRecording(frame, {**test.meta, "quantity": other})


#: The bench passage family (registered as ``"passage"``).
PASSAGE = PassageFamily()
