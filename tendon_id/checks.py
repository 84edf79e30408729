"""Checks of a setting's value, each raising one :class:`~tendon_id.errors.ConfigError` that names the setting.

Every library function that takes a choice, a count or a positive quantity checks it here, so
that every message has the same shape (``frames: must be at least 2, got 1``) and names the
*parameter*; the command line maps a parameter to its flag (``--frames``) when it prints the
error (:meth:`tendon_id.errors.ConfigError.message_for`). Written for tendon-id rather than taken
from scikit-learn's ``check_scalar``, whose messages name types and intervals in Python's
words, not the parameter's meaning.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from tendon_id.errors import ConfigError, NonFiniteResult

__all__ = [
    "check_choice",
    "check_choices",
    "check_count",
    "check_finite_result",
    "check_jobs",
    "check_keys",
    "check_positive",
    "non_finite_paths",
    "one_of",
]


def one_of(known: Iterable[str]) -> str:
    """``"a, b or c"``: the known values of a choice, for a message."""
    names = [str(k) for k in known]
    return ", ".join(names[:-1]) + f" or {names[-1]}" if len(names) > 1 else "".join(names)


def check_choice(param: str, value: Any, known: Iterable[str], *, what: str | None = None) -> str:
    """``value`` if it is one of ``known``; else a ConfigError naming ``param`` and listing ``known``.

    Parameters
    ----------
    param : str
        The parameter's name (``"model"``, ``"direction"``), which the error names.
    value : object
        The value given.
    known : iterable of str
        The values allowed, in the order the message lists them.
    what : str, optional
        What a value is, for the message (``"model"``, ``"effect"``); default: ``param``.
    """
    known = list(known)
    if value not in known:
        raise ConfigError(f"unknown {what or param} {value!r}; known: {', '.join(map(str, known))}", param=param)
    return value


def check_choices(param: str, values: Iterable[Any], known: Iterable[str], *, what: str | None = None) -> list:
    """Each of ``values`` checked by :func:`check_choice` (the first unknown one is named), in order, once each."""
    known = list(known)
    out = []
    for v in values:
        check_choice(param, v, known, what=what)
        if v not in out:
            out.append(v)
    return out


def check_keys(
    keys: Iterable[str], known: Iterable[str], *, what: str = "setting", where: str = "", param: str | None = None
) -> None:
    """Raise a ConfigError naming the keys of ``keys`` (a table's, a dict's) that are not in ``known``.

    Parameters
    ----------
    keys, known : iterable of str
        The keys given, and those allowed.
    what : str
        What a key is, for the message (``"robot setting"``, ``"section"``).
    where : str, optional
        Where they were given (a file and table), the message's prefix.
    param : str, optional
        The parameter that held them, which the error names.
    """
    known = list(known)
    unknown = sorted({str(k) for k in keys} - {str(k) for k in known})
    if unknown:
        prefix = f"{where}: " if where else ""
        raise ConfigError(
            f"{prefix}unknown {what}(s) {', '.join(map(repr, unknown))}; known: {', '.join(sorted(map(str, known)))}",
            param=param,
        )


def check_count(param: str, value: Any, minimum: int = 1) -> int:
    """``value`` as an int if it is a whole number of at least ``minimum``; else a ConfigError naming ``param``."""
    if isinstance(value, bool) or not hasattr(value, "__index__"):  # ints and numpy's integers
        raise ConfigError(f"must be a whole number, got {value!r}", param=param)
    if int(value) < minimum:
        raise ConfigError(f"must be at least {minimum}, got {value}", param=param)
    return int(value)


def check_jobs(param: str, value: Any) -> int:
    """``value`` as joblib's ``n_jobs``: a whole number of workers, or -1 for every core (-2 all but one, ...)."""
    if isinstance(value, bool) or not hasattr(value, "__index__") or int(value) == 0:
        raise ConfigError(f"must be a number of workers (1, 2, ...) or -1 for every core, got {value!r}", param=param)
    return int(value)


def check_positive(param: str, value: Any, unit: str = "", *, allow_zero: bool = False) -> float:
    """``value`` as a float if it is finite and positive (or zero, with ``allow_zero``); else a ConfigError."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    ok = v >= 0 if allow_zero else v > 0
    if not (ok and v < float("inf")):
        kind = "non-negative" if allow_zero else "positive"
        raise ConfigError(f"must be a {kind} number{' in ' + unit if unit else ''}, got {value!r}", param=param)
    return v


def non_finite_paths(obj: Any, prefix: str = "", undefined: Iterable[str] = ()) -> list[str]:
    """Where ``obj`` (nested dicts, lists, arrays and numbers) holds NaN or inf, as ``a.b[2]`` paths.

    Entries whose key is in ``undefined`` may be NaN (a value that is undefined, written as null).
    """
    undefined = tuple(undefined)
    if isinstance(obj, Mapping):
        return [
            p
            for k, v in obj.items()
            if k not in undefined
            for p in non_finite_paths(v, f"{prefix}.{k}" if prefix else str(k), undefined)
        ]
    if isinstance(obj, np.ndarray) and obj.dtype.kind in "fc":
        bad = np.argwhere(~np.isfinite(obj))
        return [f"{prefix}[{', '.join(map(str, bad[0]))}]" if obj.ndim else prefix] if bad.size else []
    if isinstance(obj, (list, tuple)):
        return [p for i, v in enumerate(obj) for p in non_finite_paths(v, f"{prefix}[{i}]", undefined)]
    if isinstance(obj, (float, np.floating)) and not math.isfinite(obj):
        return [prefix]
    return []


def check_finite_result(obj: Any, *, what: str, inputs: str, undefined: Iterable[str] = ()) -> None:
    """Raise :class:`~tendon_id.errors.NonFiniteResult` where ``obj`` holds NaN or inf; a result never does.

    Parameters
    ----------
    obj : dict, list, array or number
        The result (fitted parameters, metrics).
    what : str
        What computed it (``"calibrating passage-capstan"``).
    inputs : str
        The inputs it came from (the files), named in the message.
    undefined : iterable of str
        Keys whose value may be NaN: undefined, not wrong (R^2 of a constant reference).
    """
    bad = non_finite_paths(obj, undefined=undefined)
    if bad:
        more = f" (and {len(bad) - 1} more)" if len(bad) > 1 else ""
        raise NonFiniteResult(
            f"{what} on {inputs} gave a non-finite {bad[0]}{more}: the data's values or the settings are "
            "outside what the model can compute with; no result was written"
        )
