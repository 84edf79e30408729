"""A transmission family: the one seam between the code written once and each kind of transmission.

tendon-id models two kinds of transmission (:doc:`/guide/architecture`): the **snake chain**
(every tendon set of a snake robot through its guides) and the **bench passage** (one tendon,
or an antagonistic pair, over one passage on a bench). The diagnosis (where, which, how far,
verdict), the calibration and its files, the posterior, the evaluation, the reports and
:func:`~tendon_id.zoo.testing.check_model` are written once; they ask a model (or a recording)
for its family and call the hooks below. A family supplies, in the spirit of pysindy's model
composed of a library, an optimizer and a differentiation:

========================  ============================================================
part                      hooks
========================  ============================================================
its data                  :attr:`Family.recording` (a :class:`~tendon_id.data.frame.FrameRecording`),
                          :meth:`Family.inputs` (the adapter), :meth:`Family.unit`
its blocks                :attr:`Family.blocks` (a :class:`~tendon_id.family.blocks.BlockRegistry`),
                          :meth:`Family.effects`, :meth:`Family.block_values`
its fit and refit         :meth:`Family.start`, :meth:`Family.merge`, :meth:`Family.refit`,
                          :meth:`Family.residual`
its diagnosis             :meth:`Family.splits`, :meth:`Family.candidates`, :meth:`Family.strata`,
                          :meth:`Family.signatures`, :meth:`Family.noise_floor`
its posterior             :meth:`Family.likelihood`
its reports               :meth:`Family.calibration_doc`, :meth:`Family.calibration_lines`,
                          :meth:`Family.calibration_figures`, :meth:`Family.score_lines`
its contract              :meth:`Family.check_predictions`, :meth:`Family.check_labels_only`,
                          :meth:`Family.foreign_data`
========================  ============================================================

A model class and a recording class name their family in their ``family`` attribute
(``family_named("snake")``, resolved by :func:`tendon_id.family.get_family`). A new family is a subclass of
:class:`Family` and :func:`tendon_id.family.register_family`: no file of the library changes
(``tests/test_family_seam.py`` adds a toy one).
"""

from __future__ import annotations

import abc
from collections.abc import Iterable, Sequence
from typing import Any, ClassVar

from tendon_id.errors import ConfigError
from tendon_id.family.blocks import BlockRegistry
from tendon_id.family.fit import Fit

__all__ = ["Family"]


class Family(abc.ABC):
    """A family of transmission models (see the module docstring for the hooks by part).

    Attributes
    ----------
    name : str
        Registry name (``"snake"``, ``"passage"``), which ``family_named`` looks up.
    title : str
        What it is, in words, for messages (``"snake chain"``).
    recording : type
        Its recording class.
    blocks : BlockRegistry
        Its effect blocks, the diagnosis's candidates.
    min_rung_gain : float
        Default share of the gap a rung of the diagnosis's ladder must close besides being
        significant (:class:`~tendon_id.diagnosis.DiagnosisSettings`).
    predict_methods : tuple of str
        The model methods that predict (all must raise ``NotFittedError`` before ``fit`` and
        have no side effects).
    splits_read_the_fit : bool
        Whether :meth:`splits` reads the fitted base (the snake chain's geometry). Where it does
        not, the diagnosis fits an unfitted base on the splits' stacked signals, after letting go
        of the recordings, rather than on the recordings.
    """

    name: ClassVar[str] = ""
    title: ClassVar[str] = ""
    recording: ClassVar[type] = object
    blocks: ClassVar[BlockRegistry]
    min_rung_gain: ClassVar[float] = 0.0
    predict_methods: ClassVar[tuple[str, ...]] = ("predict",)
    splits_read_the_fit: ClassVar[bool] = True

    def __repr__(self) -> str:
        return f"<{self.title or self.name} family>"

    # ---- its data ---------------------------------------------------------------------
    def recordings(self, data, param: str = "data") -> list:
        """``data`` (one recording or a sequence) as a non-empty list of this family's recordings."""
        recs = [data] if isinstance(data, self.recording) else list(data) if isinstance(data, Sequence) else [data]
        if not recs or not all(isinstance(r, self.recording) for r in recs):
            got = type(recs[0]).__name__ if recs else "nothing"
            raise ConfigError(f"expected {self.title} recordings ({self.recording.__name__}), got {got}", param=param)
        return recs

    @abc.abstractmethod
    def inputs(self, data, model=None) -> Any:
        """The arrays a model of this family reads from ``data`` (recordings, or inputs already).

        With a fitted ``model``, the data is checked against what it was fitted on (robot size,
        quantity) and read with its settings (geometry).
        """

    def unit(self, inputs) -> str:
        """Unit of what the models predict, for reports (``"N"``)."""
        return "N"

    # ---- its blocks --------------------------------------------------------------------
    def check_base(self, model) -> None:
        """Raise ConfigError unless ``model`` is composed of blocks that candidates can extend."""

    def effects(self, model) -> set[str]:
        """The effects whose blocks ``model`` has."""
        return {b.effect for b in model.block_objects if b.effect}

    @abc.abstractmethod
    def block_values(self, model, block) -> dict[str, float]:
        """A fitted ``model``'s values of ``block``'s free parameters ``{param: value}``."""

    # ---- its fit and refit ------------------------------------------------------------------
    @abc.abstractmethod
    def start(self, model) -> Any:
        """A fitted ``model``'s parameters, as the start of a :meth:`refit`."""

    @abc.abstractmethod
    def merge(self, current, single) -> Any:
        """A refit's start: the fitted model ``current``, plus the block values of ``single`` (fitted, or None)."""

    @abc.abstractmethod
    def refit(self, structure, inputs, start, max_nfev: int, tol: float | None = None) -> Fit:
        """Fit ``structure`` (unfitted) on ``inputs`` from ``start``, locally; ``Fit.model`` is the fitted one.

        ``tol`` is the relative change at which the refit may stop, where the family's optimiser
        takes one (None: the family's own); the diagnosis's null draws ask for a looser one.
        """

    @abc.abstractmethod
    def residual(self, model, inputs):
        """Measured minus predicted, shape (T, C), NaN in the model's warm-up."""

    # ---- its diagnosis ------------------------------------------------------------------------
    @abc.abstractmethod
    def splits(self, train: list, test: list | None, folds: int, base) -> tuple[list, str]:
        """Training and held-out inputs (:class:`~tendon_id.diagnosis.splits.Split`), and the validation in words."""

    def candidates(self, base, inputs, effects: list[str]) -> dict:
        """The candidate block of each effect to add to the fitted ``base``, on training ``inputs``.

        Default: each block with its neutral settings. A family whose blocks localise (a worn
        guide: which one?) overrides this.
        """
        return {e: self.blocks[e]() for e in effects}

    @abc.abstractmethod
    def strata(self, inputs) -> Iterable[tuple[str, str, Any]]:
        """``(name, kind, mask)`` of the strata of the gap map; masks of shape (T,) or (T, C).

        Read once, in order: a generator may make each mask only when it is read.
        """

    @abc.abstractmethod
    def signatures(self, structure, fitted, inputs, blocks: dict):
        """The signatures of ``blocks`` added to ``structure`` at ``fitted``'s law (a diagnosis ``Library``)."""

    @abc.abstractmethod
    def noise_floor(self, split, model, inputs, residual, rng, settings):
        """What a perfect model's held-out error would be (:class:`~tendon_id.diagnosis.stats.NoiseFloor`)."""

    def simulate_null(self, split, model, rng, draws: int = 1):
        """``draws`` splits of data simulated as if the fitted ``model`` were the truth, read by the split's sensors.

        What calibrates the diagnosis's paired test (:mod:`~tendon_id.diagnosis.calibrate`).  Default
        None: a family that knows nothing of its sensors keeps the settings' fixed margins.
        """
        return None

    # ---- its posterior ------------------------------------------------------------------------
    @abc.abstractmethod
    def likelihood(self, model, data, **options):
        """The posterior of a fitted ``model``'s law on ``data`` (a ``calibration.posterior.Likelihood``)."""

    @abc.abstractmethod
    def law_models(self) -> list[str]:
        """The registered models of this family that ``tendon-id calibrate`` fits (those with a law)."""

    # ---- its reports --------------------------------------------------------------------------
    @abc.abstractmethod
    def calibration_doc(self, model, recordings: list) -> dict:
        """``calibration.json`` of a calibrated ``model``."""

    def calibration_lines(self, model, doc: dict) -> list[str]:
        """Lines that ``tendon-id calibrate`` prints about ``doc`` (default none)."""
        return []

    def calibration_figures(self, doc: dict) -> dict:
        """The headline numbers of ``calibration.json`` ``doc``, one row of a fleet's summary.

        ``{"rmse": float, "unit": str, "loss": float or None}``: the calibrated model's RMSE on its
        data in ``unit``, and the optimiser's loss where the family has one besides the RMSE
        (:func:`tendon_id.report.fleet.calibrate_fleet`). Default: none (an empty dict).
        """
        return {}

    @abc.abstractmethod
    def score_lines(self, model, score: dict, recording, name: str) -> list[str]:
        """``tendon-id evaluate``'s lines for ``model.score(recording)``; ``name`` is the data's file."""

    # ---- its contract (check_model) ---------------------------------------------------------------
    @abc.abstractmethod
    def check_predictions(self, model, test):
        """Assert the shapes of a fitted ``model``'s predictions on ``test``; returns ``model.predict(test)``."""

    def check_labels_only(self, model, train, test, pred, seed: int) -> None:
        """Assert that ``model`` (unfitted) fits on the labels a robot gives, nothing more (default: none to hide)."""

    @abc.abstractmethod
    def foreign_data(self, test):
        """A valid recording that a model fitted on ``test``'s kind of data must refuse with ConfigError."""
