"""Wrap-stage blocks: which wrap angle the friction law sees."""

from __future__ import annotations

from dataclasses import dataclass

from numpy.typing import NDArray

from tendon_id.errors import ConfigError
from tendon_id.geometry import exact_wrap, projected_wrap, tendon_azimuths
from tendon_id.zoo.blocks.base import Block


@dataclass(frozen=True)
class PerTendonWrap(Block):
    """Each tendon's own wrap instead of the backbone angle (:doc:`/guide/geometry`, ``per_tendon_wrap``).

    The turns of the hole points without the routing wrap, which the routing stage adds
    (:class:`~tendon_id.zoo.blocks.geometric.RoutingWrap`, fitted).

    Parameters
    ----------
    model : {"exact", "projected"}
        Forward kinematics of the hole points (:func:`tendon_id.geometry.exact_wrap`) or
        their expansion to second order in the bends (:func:`tendon_id.geometry.projected_wrap`).
    """

    name = "per_tendon_wrap"
    effect = "per_tendon_wrap"
    stage = "wrap"
    per_tendon = True
    regressor = "difference of per-tendon and backbone exponents: residual depends on bending direction"
    model: str = "exact"

    def __post_init__(self) -> None:
        if self.model not in ("exact", "projected"):
            raise ConfigError(f"per_tendon_wrap.model must be 'exact' or 'projected', got {self.model!r}")

    def settings(self) -> dict:
        return {"model": self.model}

    def wrap(self, alpha: NDArray, ctx, values: dict) -> NDArray:
        inputs, geometry = ctx.inputs, ctx.inputs.geometry

        def compute():
            # alpha_0 = 0: the robot's routing wrap in its metadata is the simulator's truth; the
            # model's own, fitted, is added at the routing stage.
            wraps = exact_wrap if self.model == "exact" else projected_wrap
            return wraps(inputs.angles, geometry, tendon_azimuths(geometry), alpha_0=0.0)

        full = inputs.memo(f"{self.model}_turns", compute)  # (T, K, N, 3)
        return full[:, :, ctx.sets][..., ctx.tendons]
