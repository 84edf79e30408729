"""The robot's description: :class:`RobotGeometry` and its tendons' hole azimuths (:doc:`/guide/robot_file`).

What a robot file or a recording's ``robot`` metadata holds, checked and in SI: module and tendon
counts, bending axes, lengths, hole azimuths and the simulator's truth. The formulas on it (wraps,
bends, the Cardan joint) are :mod:`tendon_id.geometry`'s; robot files are read by
:mod:`tendon_id.robot_file`.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import numpy as np
from numpy.typing import NDArray

from tendon_id.checks import check_keys
from tendon_id.errors import ConfigError

__all__ = ["ANGLES", "LENGTHS", "MEASURED", "RobotGeometry", "si_description", "tendon_azimuths"]


#: The optional sizes a user measures on the robot [m] (:class:`RobotGeometry`).
MEASURED = ("hole_diameter", "tendon_diameter", "hole_length")
#: The lengths [m] and angles [rad] of a robot, which a description may give with a unit ("20 mm", "10 deg").
LENGTHS = ("link_length", "joint_gap", "hole_radius") + MEASURED
ANGLES = ("alpha_0", "alpha_c", "azimuth_step")
#: The fields whose default is left out of :meth:`RobotGeometry.to_dict`, so that a 3-tendon robot's
#: metadata, recipe hash and cached recordings are those written before the fields existed.
_QUIET_DEFAULTS = {"n_tendons": 3, "bending_axes": 2, "azimuths": None}


@dataclass(frozen=True)
class RobotGeometry:
    """Description of a discrete-joint CDHRR with serial pass-through routing.

    The defaults describe a 12-module robot of the SJTU-Snake III's class (paper
    Section IV-A); the paper gives no dimensions, so the lengths are typical of
    such robots and only enter :func:`exact_wrap`.

    Parameters
    ----------
    n_modules : int
        Number of modules / joints ``N``. Default 12.
    link_length : float
        Distance between a link's two hole planes [m]. Default 0.060.
    joint_gap : float
        Distance between the hole planes on either side of a joint [m]; the
        joint's pivot sits half-way. Default 0.010.
    hole_radius : float
        Radius of the circle of tendon holes on each disk [m]. Default 0.012.
    alpha_0 : float
        Routing wrap present even when the robot is straight [rad]
        (:doc:`/guide/geometry`). Default 0.05. The simulator's truth: no model reads
        it (the capstan models fit it).
    alpha_c : float
        Clearance angle of a hole: below it the tendon does not touch the
        wall [rad]. Default 0.08, above ``alpha_0``, so a nearly straight
        guide is out of contact. The simulator's truth: no model reads it (the
        contact block fits it).
    azimuth_step : float
        Azimuth offset ``delta`` between consecutive tendon sets [rad]. The
        default ``2 pi / 36`` spreads the 36 holes of 12 sets evenly.
    hole_diameter, tendon_diameter, hole_length : float, optional
        Diameter of a guide hole, of the tendon, and the length of the hole's bore (the
        disk's thickness) [m]: what a user can measure on the robot. Together they give the
        clearance angle the contact block starts from
        (:func:`tendon_id.zoo.blocks.geometric.clearance_start`); the simulator does not read
        them. Default None (unknown).
    n_tendons : int
        Tendons per set ``n >= 2`` (every set has the same count). Default 3, the paper's.
        Two is an antagonistic pair (a planar joint), four two pairs.
    bending_axes : int
        1 (a planar robot: every joint bends about its y axis only, so ``theta_y = 0``) or 2
        (a Cardan joint, the paper's). Default 2.
    azimuths : tuple of tuple of float, optional
        Hole azimuths [rad] (:func:`tendon_azimuths`): one row of ``n`` (every set's pattern, turned by
        ``(j-1) azimuth_step`` for set ``j``) or ``N`` rows (each set's own holes). Default None:
        ``n`` holes spread evenly, ``2 pi (i-1)/n``.
    """

    n_modules: int = 12
    link_length: float = 0.060
    joint_gap: float = 0.010
    hole_radius: float = 0.012
    alpha_0: float = 0.05
    alpha_c: float = 0.08
    azimuth_step: float = 2.0 * np.pi / 36.0
    hole_diameter: float | None = None
    tendon_diameter: float | None = None
    hole_length: float | None = None
    n_tendons: int = 3
    bending_axes: int = 2
    azimuths: tuple[tuple[float, ...], ...] | None = None

    def __post_init__(self) -> None:
        # A robot often comes from a file's metadata or a --set option: text or null is a user's mistake
        # (the measured sizes may be left out: None).
        for f in fields(self):
            v = getattr(self, f.name)
            if v is None and f.name in MEASURED + ("azimuths",):
                continue
            if f.name == "azimuths":
                object.__setattr__(self, "azimuths", _azimuth_rows(v, self.n_modules, self.n_tendons))
                continue
            number = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))
            if not number or not np.isfinite(v):
                raise ConfigError(f"robot.{f.name} must be a finite number, got {v!r}")
        if int(self.n_modules) != self.n_modules or self.n_modules < 2:
            raise ConfigError(f"robot.n_modules must be an integer >= 2, got {self.n_modules!r}")
        if int(self.n_tendons) != self.n_tendons or self.n_tendons < 2:
            raise ConfigError(f"robot.n_tendons must be an integer >= 2 (tendons per set), got {self.n_tendons!r}")
        if self.bending_axes not in (1, 2):
            raise ConfigError(f"robot.bending_axes must be 1 (planar) or 2, got {self.bending_axes!r}")
        # Stored as ints, so that to_dict and the metadata write 4, not 4.0.
        for name in ("n_modules", "n_tendons", "bending_axes"):
            object.__setattr__(self, name, int(getattr(self, name)))
        for name in ("link_length", "joint_gap", "hole_radius") + MEASURED:
            v = getattr(self, name)
            if v is not None and not float(v) > 0:
                raise ConfigError(f"robot.{name} must be a positive length in m, got {v!r}")
        for name in ("alpha_0", "alpha_c"):
            v = float(getattr(self, name))
            if not 0.0 <= v < np.pi / 2:
                raise ConfigError(f"robot.{name} must be an angle in [0, pi/2) rad, got {v!r}")
        if None not in (self.hole_diameter, self.tendon_diameter) and not self.hole_diameter > self.tendon_diameter:
            raise ConfigError(f"robot.hole_diameter must exceed robot.tendon_diameter, got {self.hole_diameter!r}")

    @property
    def n_guides(self) -> int:
        """Number of guides, ``N - 1``."""
        return self.n_modules - 1

    def to_dict(self) -> dict:
        """Plain-JSON form, as stored in recording metadata.

        Unknown sizes are left out, and so are a 3-tendon, two-axis robot's defaults: the paper
        robot's metadata and recipe hash are those of before the tendon count could change.
        """
        out = {}
        for k, v in asdict(self).items():
            if v is None or (k in _QUIET_DEFAULTS and v == _QUIET_DEFAULTS[k]):
                continue
            out[k] = [list(row) for row in v] if k == "azimuths" else (float(v) if isinstance(v, float) else v)
        return out

    @classmethod
    def from_dict(cls, d: dict | None) -> RobotGeometry:
        """Build from :meth:`to_dict` output, or a description whose lengths and angles carry units.

        ``hole_radius = "12 mm"`` and ``azimuth_step = "10 deg"`` are converted to SI through pint
        (:func:`tendon_id.data.units.si_factor`); a bare number is SI already. Unknown keys are an error.
        """
        d = dict(d or {})
        known = {f.name for f in fields(cls)}
        check_keys(d, known, what="robot setting", param="robot")
        return cls(**si_description(d))


def si_description(d: dict) -> dict:
    """A robot description with its lengths [m] and angles [rad] in SI: ``"12 mm"`` becomes 0.012.

    Only the keys given are returned (a bare number is SI already); what is left out stays left out.
    """
    d = dict(d)
    for name in LENGTHS + ANGLES:
        if isinstance(d.get(name), str):
            d[name] = _with_unit(d[name], "length" if name in LENGTHS else "angle", f"robot.{name}")
    if d.get("azimuths") is not None and isinstance(d["azimuths"], (list, tuple)):
        d["azimuths"] = _rows_with_units(d["azimuths"])
    return d


def _with_unit(value: str, kind: str, where: str) -> float:
    """A length [m] or angle [rad] written with its unit; the unit is required (a bare "0.01" is ambiguous)."""
    from tendon_id.data.units import si_factor

    return si_factor(value, kind, where=where)


def _rows_with_units(value) -> list:
    """Azimuths as one row or rows of numbers [rad] or strings with units ("90 deg")."""
    rows = value if len(value) and isinstance(value[0], (list, tuple)) else [value]
    out = [[_with_unit(v, "angle", "robot.azimuths") if isinstance(v, str) else v for v in row] for row in rows]
    return out


def _azimuth_rows(value, n_modules: int, n_tendons: int) -> tuple[tuple[float, ...], ...]:
    """Explicit azimuths as a tuple of rows [rad]: one row (a pattern) or one per set, each of n_tendons."""
    try:
        rows = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"robot.azimuths must be numbers [rad] in rows of n_tendons, got {value!r}") from None
    if rows.ndim == 1:
        rows = rows[None, :]
    if rows.ndim != 2 or rows.shape[1] != n_tendons or rows.shape[0] not in (1, n_modules):
        raise ConfigError(
            f"robot.azimuths must be one row of {n_tendons} azimuths or {n_modules} rows of them "
            f"(one per set), got shape {rows.shape}"
        )
    if not np.all(np.isfinite(rows)):
        raise ConfigError(f"robot.azimuths must be finite, got {value!r}")
    # Two holes of one set at one azimuth would be one tendon counted twice.
    wrapped = np.sort(np.mod(rows, 2.0 * np.pi), axis=1)
    gaps = np.diff(np.concatenate([wrapped, wrapped[:, :1] + 2.0 * np.pi], axis=1), axis=1)
    if np.any(gaps < 1e-6):
        raise ConfigError("robot.azimuths: two tendons of one set share an azimuth")
    return tuple(tuple(float(v) for v in row) for row in rows)


def tendon_azimuths(geometry: RobotGeometry) -> NDArray[np.float64]:
    """Hole azimuths ``psi[j-1, i-1]`` [rad], shape (N, n).

    By default ``psi = 2 pi (i-1)/n + (j-1) delta``: each set's ``n`` holes spread evenly, each set
    turned by ``delta = azimuth_step`` from the last (for ``n = 3`` the paper robot's pattern).
    ``geometry.azimuths`` gives one row (the pattern, still turned by ``delta`` per set) or one row
    per set (taken as it is).
    """
    j = np.arange(geometry.n_modules)[:, None]
    n = geometry.n_tendons
    if geometry.azimuths is None:
        i = np.arange(n)[None, :]
        return 2.0 * np.pi * i / n + j * geometry.azimuth_step
    rows = np.asarray(geometry.azimuths, dtype=float)
    if rows.shape[0] == 1:
        return rows + j * geometry.azimuth_step
    return rows[: geometry.n_modules].copy()
