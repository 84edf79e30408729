"""Robot files: a robot described in TOML, with units (:doc:`/guide/robot_file`).

A robot file names what a user measures on their robot: the module count, the tendons per set
and their hole azimuths, the radii and lengths (with units, read through pint), and whether a
joint bends about one axis or two. The paper's robot is ``datasets/robots/snake12-paper.toml``::

    name = "snake12-paper"
    n_modules = 12
    n_tendons = 3              # tendons per set, any number >= 2
    bending_axes = 2           # 1: planar, 2: Cardan
    link_length = "60 mm"
    joint_gap = "10 mm"
    hole_radius = "12 mm"

    [azimuths]                 # each set's holes: a pattern, or the holes themselves
    pattern = "even"           # n holes spread evenly, 360 deg (i-1)/n
    step = "10 deg"            # each set turned from the last by this

    [simulator]                # the simulator's truth: no model reads them
    alpha_0 = "0.05 rad"
    alpha_c = "0.08 rad"

``[azimuths]`` may instead give ``first = ["0 deg", "90 deg", ...]`` (one set's holes, turned by
``step`` for each next set) or ``sets = [[...], ...]`` (every set's own holes, N rows). Optional
``[measured]`` sizes (``hole_diameter``, ``tendon_diameter``, ``hole_length``) set the contact
block's starting clearance. A number without a unit is SI (m, rad).

Wherever a robot is described (a recipe's ``[robot]``, a mapping's ``[meta] robot``), the text
``file = "NAME-or-PATH"`` reads a robot file, and the other keys beside it override its values.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from tendon_id.checks import check_keys
from tendon_id.errors import ConfigError
from tendon_id.robot import MEASURED, RobotGeometry

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

__all__ = ["bundled_dir", "load_robot", "robot_description", "robot_names", "resolve_robot"]

_TOP = {"name", "description", "n_modules", "n_tendons", "bending_axes", "azimuths", "simulator", "measured"}
_TOP |= {"link_length", "joint_gap", "hole_radius"}
_AZIMUTHS = {"pattern", "step", "first", "sets"}
_SIMULATOR = {"alpha_0", "alpha_c"}


def bundled_dir() -> Path:
    """Folder of the bundled recipes and robots: inside an installed wheel, else the checkout's ``datasets/``."""
    bundled = Path(__file__).parent / "_recipes"
    if bundled.is_dir():
        return bundled
    return Path(__file__).resolve().parents[1] / "datasets"


def robot_names() -> list[str]:
    """Names of the bundled robot files."""
    return sorted(p.stem for p in (bundled_dir() / "robots").glob("*.toml"))


def _find(name_or_path: str | os.PathLike, base: Path | None) -> Path:
    """A robot file: a path (relative to ``base`` when not absolute), or a bundled robot's name."""
    p = Path(name_or_path)
    candidates = [p] if p.is_absolute() else ([base / p] if base is not None else []) + [p]
    for c in candidates:
        if c.is_file():
            return c
    named = bundled_dir() / "robots" / f"{name_or_path}.toml"
    if p.suffix != ".toml" and named.is_file():
        return named
    raise ConfigError(
        f"no robot file {str(name_or_path)!r} (looked in {', '.join(str(c) for c in candidates) or '.'}); "
        f"bundled robots: {', '.join(robot_names()) or 'none'}"
    )


def robot_description(doc: dict[str, Any], where: str) -> dict[str, Any]:
    """A robot file's TOML document as :meth:`RobotGeometry.from_dict` keys (units still as written).

    Raises
    ------
    ConfigError
        For unknown keys or sections, naming ``where`` and the key.
    """
    check_keys(doc, _TOP, what="robot file key", where=where)
    out = {k: v for k, v in doc.items() if k not in ("name", "description", "azimuths", "simulator", "measured")}
    for section, keys in (("simulator", _SIMULATOR), ("measured", set(MEASURED))):
        table = doc.get(section, {})
        if not isinstance(table, dict):
            raise ConfigError(f"{where}: [{section}] must be a table")
        check_keys(table, keys, what=f"[{section}] key", where=where)
        out.update(table)
    az = doc.get("azimuths", {})
    if not isinstance(az, dict):
        raise ConfigError(f"{where}: [azimuths] must be a table")
    check_keys(az, _AZIMUTHS, what="[azimuths] key", where=where)
    given = [k for k in ("pattern", "first", "sets") if k in az]
    if len(given) > 1:
        raise ConfigError(f"{where}: [azimuths] takes one of pattern, first or sets, got {', '.join(given)}")
    if az.get("pattern", "even") != "even":
        raise ConfigError(f'{where}: [azimuths] pattern must be "even" (or give first = [...] or sets = [[...]])')
    if "step" in az:
        out["azimuth_step"] = az["step"]
    if "first" in az or "sets" in az:
        out["azimuths"] = az.get("first", az.get("sets"))
    return out


def load_robot(name_or_path: str | os.PathLike, *, base: Path | None = None) -> RobotGeometry:
    """Read a robot file (a path, or a bundled robot's name such as ``"snake12-paper"``).

    Parameters
    ----------
    name_or_path : str or path
        The file, or the name of one in ``datasets/robots``.
    base : Path, optional
        Folder a relative path is read from first (the recipe's or mapping's own folder).

    Returns
    -------
    RobotGeometry

    Raises
    ------
    ConfigError
        For a missing file, invalid TOML, an unknown key or an invalid value, naming the file.
    """
    return RobotGeometry.from_dict(_read(_find(name_or_path, base)))


def _read(path: Path) -> dict[str, Any]:
    try:
        with path.open("rb") as fh:
            doc = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML ({exc})") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the robot file ({exc.strerror or exc})") from None
    try:
        desc = robot_description(doc, str(path))
        RobotGeometry.from_dict(desc)  # every value checked here, with the file named
    except ConfigError as exc:
        msg = str(exc)
        raise ConfigError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None
    return desc


def resolve_robot(value: Any, *, base: Path | None = None, where: str = "robot") -> dict[str, Any] | None:
    """A robot description with any ``file = ...`` read in: the keys beside ``file`` override the file's.

    ``value`` may be None, a table (optionally with ``file``), or the text of a file's name or path.
    The result is what :meth:`RobotGeometry.from_dict` takes, units still as written.
    """
    if value is None:
        return None
    if isinstance(value, (str, os.PathLike)):
        value = {"file": value}
    if not isinstance(value, dict):
        raise ConfigError(f"{where} must be a table of robot settings or a robot file's name, got {value!r}")
    value = dict(value)
    if "file" not in value:
        return value
    name = value.pop("file")
    if not isinstance(name, str):
        raise ConfigError(f"{where}.file must be a robot file's name or path, got {name!r}")
    return {**_read(_find(name, base)), **value}
