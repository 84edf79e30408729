"""One contract check for every model of the zoo, in the spirit of scikit-learn's ``check_estimator``.

>>> from tendon_id import zoo
>>> from tendon_id.zoo.testing import check_model
>>> check_model(zoo.make("capstan-nonsmooth"), train, test)     # doctest: +SKIP

:func:`check_model` refits a fresh copy of the model (same settings) and raises
``AssertionError`` naming the first part of the contract (``tendon_id.zoo.base``) it breaks.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from tendon_id.data import Recording
from tendon_id.data.passage import PassageRecording
from tendon_id.errors import ConfigError
from tendon_id.zoo.base import NotFittedError, TransmissionModel
from tendon_id.zoo.persistence import load_model

#: Robot metadata that ties a recording to its module count.
_SIZE_KEYS = ("n_modules", "robot")


def check_model(model: TransmissionModel, train: Recording, test: Recording, *, seed: int = 0) -> None:
    """Check that ``model`` keeps the zoo's estimator contract.

    Parameters
    ----------
    model : TransmissionModel
        An unfitted model; its settings are copied, it is not changed.
    train, test : Recording
        Data to fit on and to predict; ``train`` needs at least two trajectories for the
        models that hold one out for early stopping.
    seed : int
        Seeds the scrambled intermediate truth.

    Raises
    ------
    AssertionError
        Naming the first check that fails:

        * the errors before ``fit`` (:class:`NotFittedError`) and on a robot of another size
          (:class:`~tendon_id.errors.ConfigError`);
        * ``fit`` returns ``self``;
        * shapes of ``predict`` (T, N, 3) and ``predict_chain`` (T, N, N, 3), NaN exactly
          where ``k > j``, and ``predict`` the chain's diagonal;
        * ``predict`` has no side effects (on the model's saved state or on the data) and
          gives the same bits twice;
        * scrambled intermediate truth in ``train`` changes no prediction;
        * save -> load -> predict is bit-identical, and save -> load -> save gives the same files
          (the model's name must be registered, see :func:`tendon_id.zoo.register`).

        For a single-passage model (``train`` and ``test`` are
        :class:`~tendon_id.data.passage.PassageRecording`), ``predict`` has shape (T,), there is
        no chain or hidden truth, and a passage of the other quantity must raise ConfigError.
    """
    fitted = _check_fit_and_unfitted_errors(model, train, test)
    if isinstance(test, PassageRecording):  # a single passage: no chain, no hidden truth
        pred = fitted.predict(test)
        assert pred.shape == (test.n_frames,), f"{model.name}: predict shape {pred.shape}, expected {(test.n_frames,)}"
        _check_no_side_effects(fitted, test, pred)
        _check_round_trip(fitted, test, pred)
        _check_other_quantity(fitted, test)
        return
    pred = _check_shapes(fitted, test)
    _check_no_side_effects(fitted, test, pred)
    _check_scrambled_truth_changes_nothing(model, train, test, pred, seed)
    _check_round_trip(fitted, test, pred)
    _check_other_robot_size(fitted, test)


def clone(model: TransmissionModel) -> TransmissionModel:
    """An unfitted copy with the same settings (scikit-learn's ``clone``)."""
    return type(model)(**model.get_params())


def _check_fit_and_unfitted_errors(model: TransmissionModel, train: Recording, test: Recording) -> TransmissionModel:
    fresh = clone(model)
    with tempfile.TemporaryDirectory() as tmp:  # a model that wrongly saves unfitted writes only here
        calls = [("predict", lambda: fresh.predict(test)), ("save", lambda: fresh.save(Path(tmp) / "unfitted"))]
        if hasattr(fresh, "predict_chain"):
            calls.append(("predict_chain", lambda: fresh.predict_chain(test)))
        for what, call in calls:
            try:
                call()
            except NotFittedError:
                continue
            raise AssertionError(f"{model.name}: {what} before fit must raise NotFittedError")
    assert fresh.fit(train) is fresh, f"{model.name}: fit must return self"
    return fresh


def _check_shapes(model: TransmissionModel, test: Recording) -> np.ndarray:
    t, n = test.n_frames, test.n_modules
    pred, chain = model.predict(test), model.predict_chain(test)
    assert pred.shape == (t, n, 3), f"{model.name}: predict shape {pred.shape}, expected {(t, n, 3)}"
    assert chain.shape == (t, n, n, 3), f"{model.name}: predict_chain shape {chain.shape}, expected {(t, n, n, 3)}"
    below = np.arange(n)[:, None] > np.arange(n)[None, :]
    assert np.isnan(chain[:, below]).all(), f"{model.name}: predict_chain must be NaN where k > j"
    assert np.isfinite(chain[:, ~below]).all(), f"{model.name}: predict_chain must be finite where k <= j"
    diagonal = chain[:, np.arange(n), np.arange(n)]
    assert np.array_equal(diagonal, pred), f"{model.name}: predict must be predict_chain's diagonal T[j, j]"
    return pred


def _saved(model: TransmissionModel, folder: Path) -> dict[str, bytes]:
    model.save(folder)
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def _check_no_side_effects(model: TransmissionModel, test: Recording, pred: np.ndarray) -> None:
    frame = test.frame.copy()
    with tempfile.TemporaryDirectory() as tmp:
        before = _saved(model, Path(tmp) / "before")
        again = model.predict(test)
        if hasattr(model, "predict_chain"):
            model.predict_chain(test)
        after = _saved(model, Path(tmp) / "after")
    assert before == after, f"{model.name}: predict changed the model's fitted state"
    assert test.frame.equals(frame), f"{model.name}: predict changed its input recording"
    assert _same_bits(again, pred), f"{model.name}: predict gave different results on the same data"


def _check_round_trip(model: TransmissionModel, test: Recording, pred: np.ndarray) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        saved = _saved(model, Path(tmp) / "model")
        back = load_model(Path(tmp) / "model")
        resaved = _saved(back, Path(tmp) / "again")
    assert type(back) is type(model), f"{model.name}: load gave a {type(back).__name__}"
    assert resaved == saved, f"{model.name}: save -> load -> save changed model.json or arrays.npz"
    assert _same_bits(back.predict(test), pred), f"{model.name}: save -> load -> predict is not bit-identical"


def _check_scrambled_truth_changes_nothing(
    model: TransmissionModel, train: Recording, test: Recording, pred: np.ndarray, seed: int
) -> None:
    other = clone(model).fit(scrambled_truth(train, seed))
    assert _same_bits(other.predict(test), pred), (
        f"{model.name}: scrambling the intermediate joint-side truth of the training data changed the predictions; "
        "a model must fit on terminal labels only"
    )


def _check_other_robot_size(model: TransmissionModel, test: Recording) -> None:
    smaller = _drop_last_module(test)
    try:
        model.predict(smaller)
    except ConfigError:
        return
    raise AssertionError(
        f"{model.name}: predicting a {smaller.n_modules}-module robot with a model fitted on "
        f"{model.n_modules_} modules must raise ConfigError"
    )


def _check_other_quantity(model, test) -> None:
    other = "tension" if test.quantity == "torque" else "torque"
    frame = test.frame.assign(input=test.frame["input"].abs() + 1.0, output=test.frame["output"].abs() + 1.0)
    try:
        model.predict(PassageRecording(frame, {**test.meta, "quantity": other}))
    except ConfigError:
        return
    raise AssertionError(
        f"{model.name}: predicting a {other} passage with a {test.quantity} model must raise ConfigError"
    )


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def scrambled_truth(rec: Recording, seed: int) -> Recording:
    """``rec`` with random intermediate joint-side truth [N] (kept or added), the terminal label unchanged.

    A model fitted on it must predict exactly what it predicts when fitted on ``rec``.
    """
    rng = np.random.default_rng(seed)
    n = rec.n_modules
    truth = rng.uniform(1.0, 400.0, size=(rec.n_frames, n, 3))
    truth[:, -1] = rec.terminal
    return Recording.from_arrays(
        trajectory=rec.trajectory_ids,
        t=rec.time,
        angles=rec.angles,
        actuator=rec.actuator,
        terminal=rec.terminal,
        joint_truth=truth,
        meta=rec.meta,
    )


def _drop_last_module(rec: Recording) -> Recording:
    """A valid recording of a robot one module shorter (the last module's tensions as terminal)."""
    meta = {k: v for k, v in rec.meta.items() if k not in _SIZE_KEYS}
    return Recording.from_arrays(
        trajectory=rec.trajectory_ids,
        t=rec.time,
        angles=rec.angles[:, :-1],
        actuator=rec.actuator[:, :-1],
        terminal=rec.actuator[:, -2],
        meta=meta,
    )
