"""The unit inputs of the cascade (paper Eq. (7)), built in one place for batch and streaming use.

A PG-CHTM unit at guide ``k`` reads ``sin(q_k)`` (Eq. (2)), the backbone wrap ``alpha_k``
(Eq. (3)) and the log of the tension entering the guide; the learned models of the zoo take
them from here, per frame (:func:`unit_inputs`) or padded per trajectory for a batch
(:func:`padded_unit_inputs`).  The wrap's routing part ``alpha_0`` is the calibrated prior's
(its fitted routing wrap, :attr:`~tendon_id.zoo.capstan.CapstanModel.alpha_0_`), or 0 for a
model without one: never the robot's metadata, which holds the simulator's truth.

A set has any number ``n >= 2`` of tendons; the tension inputs are one per tendon, so a model
fitted on ``n`` tendons reads only data with ``n`` (:func:`check_tendon_count`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from tendon_id.data import Recording
from tendon_id.errors import ConfigError
from tendon_id.geometry import backbone_wrap, sin_q
from tendon_id.zoo.inputs import TransmissionInputs


def check_tendon_count(recs: Sequence[Recording], n_tendons: int, model: str) -> None:
    """Raise ConfigError unless every recording has the ``n_tendons`` tendons per set ``model`` was fitted on.

    A learned unit's widths follow the tendon count (paper Eq. (7): one tension input and one ratio
    per tendon), so data with another count cannot be read, however many modules they have.
    """
    for r in recs:
        if r.n_tendons != n_tendons:
            raise ConfigError(
                f"{model} was fitted on {n_tendons} tendons per set but {r.source or 'the data'} has {r.n_tendons}"
            )


def unit_inputs(angles: NDArray, actuator: NDArray, alpha_0: float) -> tuple[NDArray, NDArray, NDArray]:
    """One frame's (or a stack of frames') unit inputs.

    Parameters
    ----------
    angles : ndarray, shape (..., N, 2)
        Joint angles [rad].
    actuator : ndarray, shape (..., N, n)
        Actuator-side tensions ``T[1, j, i]`` [N], ``n`` tendons per set.
    alpha_0 : float
        Routing wrap [rad]: the calibrated prior's, or 0.

    Returns
    -------
    sin_q : ndarray, shape (..., N-1, 4)
    alpha : ndarray, shape (..., N-1)
        Backbone wrap [rad].
    log_actuator : ndarray, shape (..., N, n)
        ``ln T[1, j, i]`` [ln N].
    """
    return sin_q(angles), backbone_wrap(angles, alpha_0), np.log(actuator)


def padded_unit_inputs(
    inputs: TransmissionInputs, pieces: Sequence[tuple[int, int]], alpha_0: float, modules: slice = slice(None)
) -> dict[str, NDArray]:
    """Unit inputs of frame ranges ``pieces`` stacked into a zero-padded batch.

    Parameters
    ----------
    inputs : TransmissionInputs
    pieces : sequence of (start, end)
        Frame ranges, one batch row each (trajectories, or chunks of them).
    alpha_0 : float
        Routing wrap [rad]: the calibrated prior's, or 0.
    modules : slice
        Which sets' actuator-side tensions to keep (all by default).

    Returns
    -------
    dict
        ``"sin_q"`` (B, L, N-1, 4), ``"alpha"`` (B, L, N-1) [rad] and ``"act"`` (B, L, M, n)
        ``ln T[1, j, i]``, with ``L`` the longest piece and ``n`` the tendons per set. Padding is zero,
        except ``"act"``, which repeats the last frame so that its logarithms stay finite (padding is
        masked out).
    """
    length = max(e - s for s, e in pieces)
    n, b = inputs.n_modules, len(pieces)
    n_sets = len(range(n)[modules])
    sq, alpha = sin_q(inputs.angles), inputs.wrap_at(alpha_0)
    out = {
        "sin_q": np.zeros((b, length, n - 1, 4)),
        "alpha": np.zeros((b, length, n - 1)),
        "act": np.zeros((b, length, n_sets, inputs.actuator.shape[-1])),
    }
    for row, (s, e) in enumerate(pieces):
        m = e - s
        out["sin_q"][row, :m], out["alpha"][row, :m] = sq[s:e], alpha[s:e]
        out["act"][row, :m] = np.log(inputs.actuator[s:e, modules])
        out["act"][row, m:] = out["act"][row, m - 1]
    return out
