"""Friction that runs in and wears with the distance slid through each guide: the ``friction_drift`` block."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from friction_models import run_in_wear_factor
from tendon_id.errors import ConfigError
from tendon_id.zoo.blocks.base import Block

#: Bounds of the fitted parameters: the run-in's fall of friction [-], the wear rate [1/m] and the
#: run-in distance [m] (a centimetre of sliding to five metres).
DRIFT_BOUNDS = {"run_in_drop": (0.0, 0.9), "wear_rate_per_m": (0.0, 2.0), "run_in_length_m": (0.01, 5.0)}
#: Run-in distance of the short-run-in signature column [m]: a run-in done within a tenth of a
#: paper-sized session's sliding (:meth:`FrictionDrift.probes`).
SHORT_RUN_IN_M = 0.05
#: A run-in fall [-] at or below which the run-in distance is inert (a thousandth of friction).
INERT_DROP = 1e-3


@dataclass(frozen=True)
class FrictionDrift(Block):
    """Each guide's friction runs in, then wears, with the distance slid through it (:doc:`/guide/simulator`).

    The capstan exponent at guide ``k`` is multiplied by

        w_k(t) = 1 - d (1 - exp(-(s0 + s_k(t)) / L)) + c (s0 + s_k(t))

    (:func:`friction_models.run_in_wear_factor`), the simulator's ``friction_drift``
    (:class:`tendon_id.sim.sensor_effects.FrictionDrift`).  ``s_k`` is the mean distance the
    tendons have slid through the guide since the first frame of the data
    (:attr:`~tendon_id.zoo.inputs.TransmissionInputs.slid`, from the measured joint angles), and
    ``s0`` what they slid before.  The exponential run-in over a characteristic sliding distance
    is the common form of a running-in curve (Blau, "On the nature of running-in", *Tribology
    International* 38 (2005) 1007-1012); the wear term is linear in the sliding distance like
    the worn volume (Archard, "Contact and rubbing of flat surfaces", *J. Appl. Phys.* 24 (1953)
    981-988).  The factor is the same for every set and tendon through a guide, so at fixed
    ``d`` and ``c`` the terminal reading's logarithm stays linear in the law.

    Parameters
    ----------
    run_in_drop : float
        Fractional fall of friction over the run-in, ``d`` [-], fitted within ``(0, 0.9)``; 0
        (default) is no run-in.
    wear_rate_per_m : float
        Rise of the multiplier per metre slid, ``c`` [1/m], fitted within ``(0, 2)``; 0 (default)
        is no wear.
    run_in_length_m : float
        Run-in distance ``L`` [m]: ``1 - exp(-1)`` of the fall is done after ``L``; fitted within
        ``(0.01, 5)`` m, from 0.5 m (default, the simulator's).  How far a pair of surfaces
        slides before it runs in depends on the materials, the load and the finish (Blau 2005),
        so no one value fits every robot; it is free, and where the data slide far less than
        ``L`` the run-in is nearly linear in the distance and ``d / L`` is what they tell.
    prior_sliding_m : float
        Distance slid through every guide before the data's first frame, ``s0`` [m], ``>= 0`` (a
        setting, not fitted).  A user rarely knows it: the default, 0, takes new guides and
        tendons at the first frame, and a guess for a robot run in before shifts where on the
        curve the data start.
    """

    name = "friction_drift"
    effect = "friction_drift"
    stage = "exponent"
    regressor = (
        "exponent of every guide times its sliding distance so far: friction falls, then rises, as the tendons "
        "slide, so the residual trends over the session clock, strongest at the guides that slide most"
    )
    run_in_drop: float = 0.0
    wear_rate_per_m: float = 0.0
    run_in_length_m: float = 0.5
    prior_sliding_m: float = 0.0
    param_names: tuple[str, ...] = ("run_in_drop", "wear_rate_per_m", "run_in_length_m")
    bounds: dict = field(default_factory=lambda: dict(DRIFT_BOUNDS))
    # The simulator's defaults: a typical magnitude of each; the run-in distance's is a short run-in.
    probe: dict = field(
        default_factory=lambda: {"run_in_drop": 0.2, "wear_rate_per_m": 0.05, "run_in_length_m": SHORT_RUN_IN_M},
        compare=False,
        repr=False,
    )

    def __post_init__(self) -> None:
        for name in ("run_in_drop", "wear_rate_per_m", "run_in_length_m", "prior_sliding_m"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
                raise ConfigError(f"friction_drift.{name} must be a number, got {value!r}")
        for name, unit in (("run_in_drop", ""), ("wear_rate_per_m", " per m")):
            lo, hi = DRIFT_BOUNDS[name]
            if not lo <= getattr(self, name) <= hi:
                raise ConfigError(f"friction_drift.{name} must lie in [{lo}, {hi}]{unit}, got {getattr(self, name)!r}")
        if not 0 < self.run_in_length_m < np.inf:  # any start: a fit clips it into its bounds
            raise ConfigError(
                f"friction_drift.run_in_length_m must be a positive distance in m, got {self.run_in_length_m!r}"
            )
        if not 0 <= self.prior_sliding_m < np.inf:
            raise ConfigError(
                f"friction_drift.prior_sliding_m must be a distance >= 0 in m, got {self.prior_sliding_m!r}"
            )

    def settings(self) -> dict:
        return {"prior_sliding_m": float(self.prior_sliding_m)}

    def inert(self, values: dict) -> tuple[str, ...]:
        """Without a run-in fall the run-in distance changes nothing: its value, bound or not, says nothing."""
        return ("run_in_length_m",) if float(values.get("run_in_drop", 0.0)) <= INERT_DROP else ()

    def probes(self) -> list[tuple[str, dict[str, float]]]:
        """Signature columns: a run-in over ``L``, a run-in over :data:`SHORT_RUN_IN_M`, and wear.

        The run-in distance alone, with no fall, changes nothing; its column is the fall over a
        short distance instead, the shape the data show when the run-in is done early in them.
        """
        base = self.initial()
        drop, wear = float(self.probe["run_in_drop"]), float(self.probe["wear_rate_per_m"])
        return [
            (f"{self.effect}:run_in_drop", {**base, "run_in_drop": drop}),
            (f"{self.effect}:run_in_length_m", {**base, "run_in_drop": drop, "run_in_length_m": SHORT_RUN_IN_M}),
            (f"{self.effect}:wear_rate_per_m", {**base, "wear_rate_per_m": wear}),
        ]

    def factor(self, slid: NDArray, values: dict) -> NDArray[np.float64]:
        """The friction multiplier ``w`` [-] of guides that have slid ``slid`` [m] since the data's first frame."""
        # An optimiser's rounding just past a bound is the bound: run_in_wear_factor refuses d < 0 or c < 0.
        d = min(max(float(values["run_in_drop"]), 0.0), DRIFT_BOUNDS["run_in_drop"][1])
        c = max(float(values["wear_rate_per_m"]), 0.0)
        length = max(float(values.get("run_in_length_m", self.run_in_length_m)), DRIFT_BOUNDS["run_in_length_m"][0])
        return run_in_wear_factor(slid + float(self.prior_sliding_m), d, length, c)

    def exponent(self, phi: NDArray, ctx, values: dict) -> NDArray:
        if values["run_in_drop"] == 0 and values["wear_rate_per_m"] == 0:
            return phi  # neutral: the base model bit for bit, and no sliding distance computed
        w = self.factor(ctx.inputs.slid, values)  # (T, K): one factor per frame and guide
        return phi * w[:, :, None, None]
