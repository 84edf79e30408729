"""Units of a user's columns, converted to SI once, at the edge (:doc:`/guide/data`).

Unit strings are parsed by pint (a maintained unit library: prefixes, products and numeric
factors such as ``"turn / 8192"`` or ``"3.9811e-5 N*m"`` come for free), and each signal's
unit must have the dimension its role needs. The registry is built on first use, so that
reading our own recordings never loads pint.
"""

from __future__ import annotations

import math
import re
from functools import lru_cache

from tendon_id.errors import ConfigError

__all__ = ["DIMENSIONS", "ANGLE_UNITS", "si_factor"]

#: The SI unit each kind of signal is stored in (a unit must have its dimension).
DIMENSIONS: dict[str, str] = {"time": "s", "angle": "rad", "tension": "N", "torque": "N*m", "length": "m"}

#: Units that make a dimensionless quantity an angle (pint gives angles no dimension, so
#: ``count`` would otherwise pass for a radian).
ANGLE_UNITS = frozenset({"radian", "degree", "turn", "revolution", "arcminute", "arcsecond", "gradian", "milliradian"})

#: What a user may write that pint does not know.
_ALIASES = {"rev": "turn", "revs": "turn", "Nm": "N*m", "mNm": "mN*m"}


@lru_cache(maxsize=1)
def _registry():
    import pint

    return pint.UnitRegistry()


#: Longest unit expression read, and largest power in one (a unit's powers are small: m**2, s**-2,
#: 10**-3); together they bound pint's work, which evaluates numbers exactly with Python's
#: integers (``10**10**8`` took minutes and ``10**400`` overflows a float).
MAX_UNIT_LENGTH, MAX_POWER = 200, 100
_POWER = re.compile(r"\*\*|\^")
_EXPONENT = re.compile(r"\s*\(?\s*([-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)\s*\)?")


def _check_bounded(text: str, unit: str, where: str) -> None:
    """Refuse a unit whose evaluation is unbounded: too long, a power of a power, or a power above :data:`MAX_POWER`."""
    if len(text) > MAX_UNIT_LENGTH:
        raise ConfigError(f"{where}: unit {unit[:40]!r}... is longer than {MAX_UNIT_LENGTH} characters")
    for op in _POWER.finditer(text):
        m = _EXPONENT.match(text, op.end())
        if m is None or _POWER.match(text[m.end() :].lstrip()):
            raise ConfigError(f"{where}: unit {unit!r}: a power's exponent must be a plain number, not an expression")
        if abs(float(m.group(1))) > MAX_POWER:
            raise ConfigError(f"{where}: unit {unit!r}: power {m.group(1)} is beyond +-{MAX_POWER}")


def _normalise(unit: str) -> str:
    text = re.sub(r"[·⋅]", "*", unit).strip()
    return re.sub(r"[A-Za-z_]+", lambda m: _ALIASES.get(m.group(0), m.group(0)), text)


def si_factor(unit: str, kind: str, *, where: str) -> float:
    """The factor from ``unit`` to the SI unit of a ``kind`` signal.

    Parameters
    ----------
    unit : str
        A unit expression: ``"deg"``, ``"mN"``, ``"N*m"``, ``"turn / 8192"``, ``"3.9811e-5 N*m"``.
    kind : str
        ``time`` [s], ``angle`` [rad], ``tension`` [N] or ``torque`` [N m].
    where : str
        Where the unit was written (the mapping file and key), named in errors.

    Returns
    -------
    float
        ``value_SI = factor * value``.

    Raises
    ------
    ConfigError
        For an unknown unit or one of the wrong dimension, in one line.
    """
    import pint

    reg = _registry()
    si = DIMENSIONS[kind]
    text = _normalise(str(unit))
    _check_bounded(text, str(unit), where)
    try:
        q = reg.parse_expression(text)
    except (pint.errors.UndefinedUnitError, pint.errors.DefinitionSyntaxError, AttributeError, TypeError) as exc:
        raise ConfigError(f"{where}: unknown unit {unit!r} ({exc})") from None
    except OverflowError:
        raise ConfigError(f"{where}: unit {unit!r} has a factor beyond float64's range") from None
    except Exception as exc:  # pint's parser raises plain errors for malformed text
        raise ConfigError(f"{where}: cannot read the unit {unit!r} ({type(exc).__name__})") from None
    if not isinstance(q, reg.Quantity):  # a bare number
        q = reg.Quantity(float(q), "dimensionless")
    if q.dimensionality != reg.parse_units(si).dimensionality:
        raise ConfigError(f"{where}: unit {unit!r} is {q.dimensionality}, but this signal is a {kind} ({si})")
    if kind == "angle" and not {name for name, _ in q.unit_items()} & ANGLE_UNITS:
        raise ConfigError(f"{where}: unit {unit!r} is not an angle; write deg, rad or turn (with a scale for counts)")
    try:
        factor = float(q.to(si).magnitude)
    except OverflowError:
        factor = float("inf")
    if not math.isfinite(factor):  # zero is a value ("0 deg" in a robot file), infinity never
        raise ConfigError(f"{where}: unit {unit!r} gives a factor of {factor:g} to {si}; it must be finite")
    return factor
