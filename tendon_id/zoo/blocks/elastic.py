"""The elastic tendon: capstan bands at the guides and linear springs between them (:doc:`/guide/simulator`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from friction_models import SLACK_FLOOR_N
from friction_models.elastic_series import elastic_series
from friction_models.kernels import play_series
from tendon_id.errors import ConfigError
from tendon_id.sliding import segment_length, segment_path_lengths
from tendon_id.zoo.blocks.base import Block

#: Axial stiffnesses [kN] a diagnosis tries as the start of its fit (:meth:`ElasticTendon.localise`):
#: the rigid chain's tension-driven limit, then a decade on either side of a 0.9 mm steel rope's 35 kN.
START_STIFFNESS_KN = (0.0, 3.5, 35.0, 350.0)


@dataclass(frozen=True)
class ElasticTendon(Block):
    """An elastic tendon through the guides' capstan bands (the simulator's ``stick_slip.driver = "elastic"``).

    Each tendon is a chain of linear springs ``k = EA / l`` between its guides (``l`` one module's
    pitch, :func:`tendon_id.sliding.segment_length`), whose path lengths follow the measured joint
    angles through the hole points (:func:`tendon_id.sliding.segment_path_lengths`); each guide
    holds a capstan band, and the quasi-static equilibrium is solved frame by frame
    (:mod:`friction_models.elastic_chain`; Kaneko, Paetsch & Tolle 1992; Agrawal, Peine & Yao
    2010). Joint motion then drives slip as well as the entering tension: a bend that lengthens
    the path beyond a guide draws the tendon through it.

    It refines ``stick_slip`` (the hysteresis block) and sets the step in its place. At
    ``EA = 0`` it is that block exactly (the play operator of each guide in turn, driven by the
    tension alone); any ``EA > 0`` is the elastic chain, which tends to the same as ``EA -> 0``
    but for the material a slipping guide passes to its neighbours (about 0.3 N RMS on a moving
    12-module robot, :doc:`/guide/simulator`).

    Parameters
    ----------
    EA_kN : float
        Axial stiffness of the tendon [kN], ``>= 0``; 0 (default) is the rigid chain's
        tension-driven limit, so a model with this block starts from its base model's fit.
    """

    name = "elastic_tendon"
    effect = "elastic_tendon"
    stage = "propagate"
    requires = ("stick_slip",)
    whole_chain = True
    regressor = "the joint side follows the joints' motion: residual while the joints move, of the sign of the bend"
    EA_kN: float = 0.0
    param_names: tuple[str, ...] = ("EA_kN",)
    bounds: dict = field(default_factory=lambda: {"EA_kN": (0.0, 1000.0)})
    # The probe is the simulator's default tendon, a 0.9 mm 7x19 stainless rope (Feyrer 2015).
    probe: dict = field(default_factory=lambda: {"EA_kN": 35.0}, compare=False, repr=False)

    def propagate(self, lo: NDArray, hi: NDArray, ctx, values: dict) -> NDArray:
        # Unreachable through a composed model: compose() refuses per-guide blocks beside this one.
        raise ConfigError("the elastic_tendon block solves every guide of a tendon at once", param="blocks")

    def propagate_series(self, log_in, phi, n_pass, ctx, values, keep_chain, start=None):
        inputs = ctx.inputs
        ea = float(values["EA_kN"]) * 1e3
        if ea <= 0.0:  # the tension-driven limit: the hysteresis block's play operators, bit for bit
            return play_series(log_in, phi, n_pass, inputs.reset, keep_chain, start)
        sets, tendons = np.asarray(ctx.sets), np.asarray(ctx.tendons)
        t, k, m = phi.shape
        # The path changes of these sets' tendons, column-major as the compiled pass reads them: a fit
        # evaluates the chain hundreds of times on the same frames.
        key = f"segment_changes:{sets.tobytes().hex()}:{tendons.tobytes().hex()}"
        dl = inputs.memo(key, lambda: _segment_changes(inputs, sets, tendons).reshape(t, k, m))
        stiffness = np.full(k, ea / segment_length(inputs.geometry))
        final, chain = elastic_series(
            np.exp(log_in),
            dl,
            phi,
            n_pass,
            stiffness,
            inputs.reset,
            floor=SLACK_FLOOR_N,
            keep_chain=keep_chain,
            start=start,
        )
        return np.log(final), None if chain is None else np.log(chain)

    @classmethod
    def localise(cls, model, inputs, A, B, values, residual: NDArray) -> ElasticTendon:
        """The stiffness of :data:`START_STIFFNESS_KN` with the least squared error [N^2] of the base's law.

        The reading changes with ``EA`` over decades (from the tension-driven to the motion-driven
        limit), so a fit started at 0 would see almost no slope: it starts from the best of a
        coarse grid, 0 included, so where no stiffness helps it starts from the base.
        """
        augmented = model.with_blocks(cls())
        keep = inputs.since_start >= float(model.warmup_s)

        def sse(ea_kn: float) -> float:
            pred = augmented.terminal_reading(inputs, A, B, {**values, cls.name: {"EA_kN": ea_kn}})
            return float(np.nansum((pred - inputs.terminal)[keep] ** 2))

        return cls(EA_kN=min(START_STIFFNESS_KN, key=sse))


def _segment_changes(inputs, sets: NDArray, tendons: NDArray) -> NDArray:
    """Change of each segment's path length since the frame before [m], 0 at trajectory starts, (T, K, S, m)."""
    length = segment_path_lengths(inputs.angles, inputs.geometry)[:, :, sets][..., tendons]
    change = np.zeros_like(length)
    change[1:] = length[1:] - length[:-1]
    change[inputs.reset] = 0.0
    return change
