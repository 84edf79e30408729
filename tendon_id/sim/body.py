"""The robot's mass and how it is mounted: the closed loop's inertia, gravity and payload (:doc:`/guide/closed_loop`).

The open-loop simulator commands the joint angles and never needs a mass; the closed loop
integrates the joints' dynamics, so it needs each link's mass for the inertia the joint carries,
and, where the robot is not supported, gravity and a payload at the tip.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tendon_id.errors import ConfigError

__all__ = ["STANDARD_GRAVITY", "Body"]

#: Standard acceleration of gravity [m/s^2] (CGPM 1901, the conventional value).
STANDARD_GRAVITY = 9.80665


@dataclass(frozen=True)
class Body:
    """Mass of the links and payload, and the base's orientation against gravity.

    Parameters
    ----------
    link_mass_kg : float
        Mass of one link with its disks [kg], its centre half-way along the link. Default 0.04:
        an aluminium tube (2700 kg/m^3) of the default link's 60 mm, 30 mm outside and 24 mm
        inside diameter, is 41 g; the paper gives no masses.
    link_radius_m : float
        Outer radius of a link [m], for its own moment of inertia (a thin-walled tube). Default 0.015.
    payload_kg : float
        Point mass at the tip, the top of the last link [kg]. Default 0.
    gravity : bool
        Whether gravity acts. Default False: the paper's robot is supported, as on a table
        or in an insertion guide, so its joints carry no weight.
    base_tilt_deg : float
        Angle of the base's axis (the straight robot's direction) from the upward vertical [deg],
        when ``gravity`` is on. Default 90: a horizontal cantilever.
    base_azimuth_deg : float
        The direction in the base's own x-y plane towards which gravity pulls the robot, measured
        from the base's +x axis [deg]. Default 0: a horizontal robot sags towards +x (positive
        ``theta_x``).
    """

    link_mass_kg: float = 0.04
    link_radius_m: float = 0.015
    payload_kg: float = 0.0
    gravity: bool = False
    base_tilt_deg: float = 90.0
    base_azimuth_deg: float = 0.0

    def __post_init__(self) -> None:
        for name in ("link_mass_kg", "link_radius_m", "payload_kg", "base_tilt_deg", "base_azimuth_deg"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
                raise ConfigError(f"body.{name} must be a finite number, got {v!r}")
        if not self.link_mass_kg > 0 or not self.link_radius_m > 0:
            raise ConfigError("body.link_mass_kg and body.link_radius_m must be positive (kg, m)")
        if self.payload_kg < 0:
            raise ConfigError(f"body.payload_kg must be >= 0 kg, got {self.payload_kg!r}")
        if not isinstance(self.gravity, bool):
            raise ConfigError(f"body.gravity must be true or false, got {self.gravity!r}")
        if not 0.0 <= self.base_tilt_deg <= 180.0:
            raise ConfigError(f"body.base_tilt_deg must lie in [0, 180] deg, got {self.base_tilt_deg!r}")

    def gravity_in_base(self) -> NDArray[np.float64]:
        """Gravity's acceleration in the base's frame [m/s^2], shape (3,); zero when ``gravity`` is off.

        The base's frame is the world's turned by ``base_tilt_deg`` about the horizontal axis at
        right angles to ``base_azimuth_deg``, so that the world's downward vertical reads
        ``g (sin t cos a, sin t sin a, -cos t)`` in it.
        """
        if not self.gravity:
            return np.zeros(3)
        t, a = np.deg2rad(self.base_tilt_deg), np.deg2rad(self.base_azimuth_deg)
        return STANDARD_GRAVITY * np.array([np.sin(t) * np.cos(a), np.sin(t) * np.sin(a), -np.cos(t)])
