"""Friction that runs in and wears with the sliding distance through a guide."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def run_in_wear_factor(
    sliding_distance_m: ArrayLike,
    run_in_drop: float,
    run_in_length_m: float,
    wear_rate_per_m: float,
    form: str = "exponential",
) -> NDArray[np.float64]:
    """Friction multiplier after sliding a distance ``s``: run-in, then wear.

        w(s) = 1 - d (1 - exp(-s / L)) + c s

    * **Run-in** (``d``, ``L``): a fresh contact's asperities are smoothed and its surfaces
      conform, so friction falls from its initial value towards a steady one; the exponential
      approach over a characteristic sliding distance is the common form of a running-in curve
      (Blau, "On the nature of running-in", *Tribology International* 38 (2005) 1007-1012).
    * **Wear** (``c``): the worn volume grows linearly with the sliding distance at a given load
      (Archard, "Contact and rubbing of flat surfaces", *J. Appl. Phys.* 24 (1953) 981-988);
      the multiplier is taken to grow in proportion to it (a roughened, grooved bore).

    ``w(0) = 1``; ``w`` falls with ``d`` and rises with ``L`` and ``c`` (for ``s > 0``), and
    stays above ``1 - d > 0``.

    Parameters
    ----------
    sliding_distance_m : array_like
        Cumulative sliding distance ``s >= 0`` [m], any shape.
    run_in_drop : float
        Fractional fall of friction over the run-in, ``d`` in ``[0, 1)`` [-].
    run_in_length_m : float
        Run-in distance ``L > 0`` [m]: ``1 - exp(-1)`` (63 %) of the fall is done after ``L``.
    wear_rate_per_m : float
        Rise of the multiplier per metre slid, ``c >= 0`` [1/m].
    form : {"exponential", "hyperbolic"}
        Shape of the run-in: ``1 - exp(-s / L)`` (default) or ``s / (s + L)``, which approaches the
        steady friction more slowly (half the fall after ``L``); both are running-in curves of
        Blau's review.

    Returns
    -------
    ndarray
        The multiplier ``w(s)`` [-], shape of ``sliding_distance_m``.
    """
    if not 0.0 <= run_in_drop < 1.0:
        raise ValueError(f"run_in_drop must lie in [0, 1), got {run_in_drop}")
    if not run_in_length_m > 0:
        raise ValueError(f"run_in_length_m must be a positive distance in m, got {run_in_length_m}")
    if not wear_rate_per_m >= 0:
        raise ValueError(f"wear_rate_per_m must be >= 0 per m, got {wear_rate_per_m}")
    if form not in ("exponential", "hyperbolic"):
        raise ValueError(f"form must be 'exponential' or 'hyperbolic', got {form!r}")
    s = np.asarray(sliding_distance_m, dtype=float)
    if np.any(s < 0):
        raise ValueError("a sliding distance is >= 0 m")
    run_in = -np.expm1(-s / run_in_length_m) if form == "exponential" else s / (s + run_in_length_m)
    return 1.0 - run_in_drop * run_in + wear_rate_per_m * s
