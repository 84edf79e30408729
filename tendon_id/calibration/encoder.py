"""Encoder quantisation in the law: which readings share an error, and the spread it gives the fit.

A quantised joint angle carries an error that is a function of the true angle, so it
does not average out like load-cell noise while a joint is held. The posterior
(:mod:`tendon_id.calibration.posterior`) convolves the covariance computed here into its chain: the
law is refitted on angles shifted by independent uniform offsets of plus or minus half an
encoder step, one per group of identical readings (a linearised errors-in-variables
marginalisation).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration.problem import LawProblem, constrained_lstsq


def encoder_runs(angles: NDArray) -> NDArray[np.int64]:
    """Group of every reading whose quantisation error is shared: one per channel and reading value.

    A quantisation error is a function of the true angle, so a joint that returns to
    the same held pose (the same reading) repeats the same error, in any trajectory.
    Readings of the same value while moving are grouped too, which errs on the side
    of more correlation (wider intervals).

    Returns
    -------
    ndarray of int, shape (T, N, 2)
        Group ids, unique over all channels.
    """
    t = angles.shape[0]
    flat = angles.reshape(t, -1)
    ids = np.empty(flat.shape, dtype=np.int64)
    offset = 0
    for c in range(flat.shape[1]):
        _, inverse = np.unique(flat[:, c], return_inverse=True)
        ids[:, c] = inverse + offset
        offset += int(inverse.max()) + 1
    return ids.reshape(angles.shape)


def encoder_covariance(model, inputs, encoder_step: float, *, n_draws: int = 64, seed: int = 0) -> NDArray[np.float64]:
    """Covariance of the law from encoder quantisation, per tendon, shape (n, p, p) for n tendons per set.

    Refits the smooth surrogate of ``model`` (a capstan model: its law and exponent blocks,
    :meth:`~tendon_id.zoo.capstan.CapstanModel.smooth_part`) on the angles of ``inputs``
    (:class:`~tendon_id.zoo.inputs.TransmissionInputs`) offset by ``U(-step/2, step/2)`` per
    group of :func:`encoder_runs`; ``encoder_step`` is the encoder's quantum [rad].
    """
    surrogate = model.smooth_part()
    values = model.block_params_  # the fitted routing wrap and clearance, held
    runs = encoder_runs(inputs.angles)
    n_runs = int(runs.max()) + 1
    rng = np.random.default_rng(seed)
    fits = []
    for _ in range(n_draws):
        offset = rng.uniform(-0.5, 0.5, size=n_runs) * encoder_step
        shifted = LawProblem.from_model(
            surrogate, dataclasses.replace(inputs, angles=inputs.angles + offset[runs]), values=values
        )
        fits.append(
            [
                constrained_lstsq(shifted.design, shifted.log_drop[:, i], shifted.layout, 1e-10).x
                for i in range(shifted.log_drop.shape[1])
            ]
        )
    fits = np.array(fits)  # (n_draws, n, p)
    return np.stack([np.atleast_2d(np.cov(fits[:, i].T)) for i in range(fits.shape[1])])
