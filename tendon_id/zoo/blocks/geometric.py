"""The robot's geometry as fitted parameters: the routing wrap and the hole's clearance (:doc:`/guide/zoo`).

A user knows a robot's lengths and radii; not the wrap its tendons keep when it is straight
(the routing wrap ``alpha_0``), nor the angle a tendon turns through a hole before it touches
the wall (the clearance ``alpha_c``).  The simulator has both as truth
(:class:`~tendon_id.geometry.RobotGeometry`), and no model reads them there: the capstan models
fit them, within :data:`ROUTING_BOUNDS` and :data:`CLEARANCE_BOUNDS`, starting from
:data:`ROUTING_START` and :func:`clearance_start`.  Both are *geometric* parameters (the law
problem is linear at any fixed value of them), which calibration profiles out
(:mod:`tendon_id.calibration.law_geometry`).

This module holds the starting values and the routing block; the clearance is the contact
block's parameter (:class:`~tendon_id.zoo.blocks.exponent.ContactGate`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from tendon_id.zoo.blocks.base import Block

#: Clearance angle a fit starts from when the robot's sizes are unknown [rad]: :func:`clearance_start`
#: of a typical guide, a 1.0 mm tendon in a 1.3 mm hole through a 3 mm disk, ``arctan(0.3 / 3)``.
CLEARANCE_START = float(np.arctan(0.1))
#: Range of a fitted clearance angle [rad]: from none to about 17 degrees, beyond any guide hole's.
CLEARANCE_BOUNDS = (0.0, 0.3)
#: Routing wrap a fit starts from [rad]: a straight robot whose holes lie on one circle routes its
#: tendons straight.  Nothing a user measures gives it.
ROUTING_START = 0.0
#: Range of a fitted routing wrap [rad], per guide.
ROUTING_BOUNDS = (0.0, 0.3)


def clearance_start(geometry) -> float:
    """The clearance angle [rad] a fit starts from: what the robot's measured sizes give, else :data:`CLEARANCE_START`.

    A tendon of diameter ``d`` tilts freely in a cylindrical hole of diameter ``D`` and length
    ``L`` until it touches the wall at both ends of the bore, at ``tan(alpha) = (D - d) / L`` to
    first order in the clearance: the wobble angle of a peg in a hole (Whitney 1982,
    "Quasi-static assembly of compliantly supported rigid parts", J. Dyn. Syst. Meas. Control
    104(1), 65-77, there ``c D / l`` with the clearance ratio ``c = (D - d) / D``).

    Parameters
    ----------
    geometry : RobotGeometry
        Its ``hole_diameter``, ``tendon_diameter`` and ``hole_length`` [m] are read; never
        ``alpha_c``, the simulator's truth.

    Returns
    -------
    float
        ``arctan((D - d) / L)`` [rad] when all three sizes are known, else :data:`CLEARANCE_START`;
        within :data:`CLEARANCE_BOUNDS`.
    """
    sizes = (geometry.hole_diameter, geometry.tendon_diameter, geometry.hole_length)
    if any(v is None for v in sizes):
        return CLEARANCE_START
    hole, tendon, length = (float(v) for v in sizes)
    return float(np.clip(np.arctan((hole - tendon) / length), *CLEARANCE_BOUNDS))


@dataclass(frozen=True)
class RoutingWrap(Block):
    """The routing wrap ``alpha_0`` [rad] every guide keeps when the robot is straight, fitted (paper Eq. (3)).

    Every capstan model has one (:class:`~tendon_id.zoo.capstan.CapstanModel` adds it when its
    blocks do not); it adds ``alpha_0`` to the wrap the wrap stage gives, the backbone wrap's
    half-bends or a tendon's own turns, so that ``alpha_k = |theta_k| / 2 + |theta_{k+1}| / 2 +
    alpha_0``, at most pi.

    Parameters
    ----------
    alpha_0 : float
        Routing wrap [rad]: the start of the fit, or the value held with ``fixed=True``.
    fixed : bool
        Hold ``alpha_0`` instead of fitting it.
    """

    name = "routing"
    effect = None
    stage = "routing"
    geometric = True
    regressor = "an offset of every guide's wrap: residual follows the count of guides a tendon passes"
    alpha_0: float = ROUTING_START
    param_names: tuple[str, ...] = ("alpha_0",)
    bounds: dict = field(default_factory=lambda: {"alpha_0": ROUTING_BOUNDS})
    probe: dict = field(default_factory=lambda: {"alpha_0": 0.05}, compare=False, repr=False)

    def routing(self, alpha: NDArray, ctx, values: dict) -> NDArray:
        # A bound-respecting optimiser may still step a rounding error below zero: no negative wrap.
        return np.minimum(alpha + max(float(values["alpha_0"]), 0.0), np.pi)
