"""Units of a user's columns, converted to SI once, at the edge (:doc:`/guide/data`).

Unit strings are parsed by pint (a maintained unit library: prefixes, products and numeric
factors such as ``"turn / 8192"`` or ``"3.9811e-5 N*m"`` come for free), and each signal's
unit must have the dimension its role needs. The registry is built on first use, so that
reading our own recordings never loads pint.
"""

from __future__ import annotations

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
    try:
        q = reg.parse_expression(_normalise(str(unit)))
    except (pint.errors.UndefinedUnitError, pint.errors.DefinitionSyntaxError, AttributeError, TypeError) as exc:
        raise ConfigError(f"{where}: unknown unit {unit!r} ({exc})") from None
    except Exception as exc:  # pint's parser raises plain errors for malformed text
        raise ConfigError(f"{where}: cannot read the unit {unit!r} ({type(exc).__name__})") from None
    if not isinstance(q, reg.Quantity):  # a bare number
        q = reg.Quantity(float(q), "dimensionless")
    if q.dimensionality != reg.parse_units(si).dimensionality:
        raise ConfigError(f"{where}: unit {unit!r} is {q.dimensionality}, but this signal is a {kind} ({si})")
    if kind == "angle" and not {name for name, _ in q.unit_items()} & ANGLE_UNITS:
        raise ConfigError(f"{where}: unit {unit!r} is not an angle; write deg, rad or turn (with a scale for counts)")
    return float(q.to(si).magnitude)
