"""One contract check for every model of the zoo, in the spirit of scikit-learn's ``check_estimator``.

>>> from tendon_id import zoo
>>> from tendon_id.zoo.testing import check_model
>>> check_model(zoo.make("capstan-nonsmooth"), train, test)     # doctest: +SKIP

:func:`check_model` refits a fresh copy of the model (same settings) and raises
``AssertionError`` naming the first part of the contract (:mod:`tendon_id.zoo.estimator`) it
breaks. It is written once: what differs by transmission family (the shapes of a prediction,
the labels a model may fit on, the data it must refuse) is the family's
(:meth:`~tendon_id.family.Family.check_predictions` and its neighbours).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from tendon_id.errors import ConfigError
from tendon_id.family.registry import family_of
from tendon_id.zoo.estimator import Estimator, NotFittedError
from tendon_id.zoo.persistence import load

__all__ = ["check_model", "clone", "same_bits"]


def check_model(model: Estimator, train, test, *, seed: int = 0) -> None:
    """Check that ``model`` keeps the zoo's estimator contract.

    Parameters
    ----------
    model : Estimator
        An unfitted model; its settings are copied, it is not changed.
    train, test : recording
        Data of the model's family to fit on and to predict; ``train`` needs at least two
        trajectories for the models that hold one out for early stopping.
    seed : int
        Seeds what the family scrambles (the snake chain's intermediate truth).

    Raises
    ------
    AssertionError
        Naming the first check that fails:

        * every predicting method (the family's :attr:`~tendon_id.family.Family.predict_methods`)
          and ``save`` raise :class:`NotFittedError` before ``fit``;
        * ``fit`` returns ``self``;
        * the shapes of the predictions (:meth:`~tendon_id.family.Family.check_predictions`:
          a snake's ``predict`` (T, N, 3) and ``predict_chain`` (T, N, N, 3), NaN exactly where
          ``k > j``; a passage's (T,));
        * ``predict`` has no side effects (on the model's saved state or on the data) and
          gives the same bits twice;
        * the model fits on the labels a robot gives and nothing more
          (:meth:`~tendon_id.family.Family.check_labels_only`: scrambled intermediate truth
          changes no snake prediction);
        * save -> load -> predict is bit-identical, and save -> load -> save gives the same files
          (the model's name must be registered, see :func:`tendon_id.zoo.register`);
        * data it was not fitted for (:meth:`~tendon_id.family.Family.foreign_data`: a robot of
          another size, a passage of the other quantity) raises ConfigError.
    """
    family = family_of(model)
    fitted = _check_fit_and_unfitted_errors(model, train, test, family.predict_methods)
    pred = family.check_predictions(fitted, test)
    _check_no_side_effects(fitted, test, pred, family.predict_methods)
    family.check_labels_only(model, train, test, pred, seed)
    _check_round_trip(fitted, test, pred)
    _check_refuses(fitted, test, family.foreign_data(test))


def clone(model: Estimator) -> Estimator:
    """An unfitted copy with the same settings (scikit-learn's ``clone``)."""
    return type(model)(**model.get_params())


def _check_fit_and_unfitted_errors(model: Estimator, train, test, methods: tuple[str, ...]) -> Estimator:
    fresh = clone(model)
    with tempfile.TemporaryDirectory() as tmp:  # a model that wrongly saves unfitted writes only here
        calls = [(m, lambda m=m: getattr(fresh, m)(test)) for m in methods]
        calls.append(("save", lambda: fresh.save(Path(tmp) / "unfitted")))
        for what, call in calls:
            try:
                call()
            except NotFittedError:
                continue
            raise AssertionError(f"{model.name}: {what} before fit must raise NotFittedError")
    assert fresh.fit(train) is fresh, f"{model.name}: fit must return self"
    return fresh


def _saved(model: Estimator, folder: Path) -> dict[str, bytes]:
    model.save(folder)
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def _check_no_side_effects(model: Estimator, test, pred: np.ndarray, methods: tuple[str, ...]) -> None:
    frame = test.frame.copy()
    with tempfile.TemporaryDirectory() as tmp:
        before = _saved(model, Path(tmp) / "before")
        again = model.predict(test)
        for m in methods:
            getattr(model, m)(test)
        after = _saved(model, Path(tmp) / "after")
    assert before == after, f"{model.name}: predict changed the model's fitted state"
    assert test.frame.equals(frame), f"{model.name}: predict changed its input recording"
    assert same_bits(again, pred), f"{model.name}: predict gave different results on the same data"


def _check_round_trip(model: Estimator, test, pred: np.ndarray) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        saved = _saved(model, Path(tmp) / "model")
        back = load(Path(tmp) / "model")
        resaved = _saved(back, Path(tmp) / "again")
    assert type(back) is type(model), f"{model.name}: load gave a {type(back).__name__}"
    assert resaved == saved, f"{model.name}: save -> load -> save changed model.json or arrays.npz"
    assert same_bits(back.predict(test), pred), f"{model.name}: save -> load -> predict is not bit-identical"


def _check_refuses(model: Estimator, test, foreign) -> None:
    try:
        model.predict(foreign)
    except ConfigError:
        return
    raise AssertionError(
        f"{model.name}: predicting data unlike what it was fitted on ({foreign!r}, after {test!r}) "
        "must raise ConfigError"
    )


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two arrays are the same to the bit (shape, dtype and bytes)."""
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()
