"""Patterns in a mapping file: one line for a whole family of columns (:doc:`/guide/data`).

A key of ``[columns]`` may hold placeholders in braces that expand over the robot's modules and
tendons, and the same placeholders in the entry's ``column`` (a CSV column's name) or ``field`` (a
ROS message's field) are filled in for each expansion::

    "theta_{k}_x" = { column = "enc{k}_pitch", unit = "deg" }
    "tension_act_{j}_{i}" = { column = "cell_{j}_{i}", unit = "mN" }
    "theta_{k}_y" = { topic = "/joint_states", field = "position[{2*k0 + 1}]" }

``k`` and ``j`` run over the modules ``1..N``, ``i`` over the tendons ``1..n``; ``k0``, ``j0`` and
``i0`` are the same minus one (a 0-based array index). A placeholder may be a small integer
expression of them (``+``, ``-``, ``*`` and whole numbers), since a log often interleaves axes or
tendons in one array. A key spelled out in full overrides the expansion of a pattern.

Why our own expander: :meth:`str.format` evaluates no arithmetic, and ``eval`` would run any code a
mapping file holds; the expressions here are parsed with :mod:`ast` and only integer arithmetic on
the names above is evaluated.
"""

from __future__ import annotations

import ast
import itertools
import re
from typing import Any

from tendon_id.errors import ConfigError

__all__ = ["PLACEHOLDER", "expand_columns", "fill", "is_pattern"]

#: A placeholder: braces around a small expression.
PLACEHOLDER = re.compile(r"\{([^{}]+)\}")
#: The loop variables and the 0-based forms a placeholder may use.
_MODULE, _TENDON = ("k", "j"), ("i",)


def is_pattern(key: str) -> bool:
    """Whether a ``[columns]`` key has placeholders."""
    return bool(PLACEHOLDER.search(key))


def _value(node: ast.AST, names: dict[str, int], text: str, where: str) -> int:
    if isinstance(node, ast.Expression):
        return _value(node.body, names, text, where)
    if isinstance(node, ast.Constant) and isinstance(node.value, int) and not isinstance(node.value, bool):
        return node.value
    if isinstance(node, ast.Name) and node.id in names:
        return names[node.id]
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        return -_value(node.operand, names, text, where)
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub, ast.Mult)):
        a, b = _value(node.left, names, text, where), _value(node.right, names, text, where)
        return a + b if isinstance(node.op, ast.Add) else a - b if isinstance(node.op, ast.Sub) else a * b
    raise ConfigError(
        f"{where}: the placeholder {{{text}}} may use only {', '.join(sorted(names))}, whole numbers and + - *"
    )


def fill(text: str, names: dict[str, int], where: str) -> str:
    """``text`` with each placeholder replaced by its integer value at ``names``."""

    def one(m: re.Match) -> str:
        expr = m.group(1).strip()
        if len(expr) > 40:
            raise ConfigError(f"{where}: the placeholder {{{expr}}} is too long")
        try:
            tree = ast.parse(expr, mode="eval")
        except SyntaxError:
            raise ConfigError(f"{where}: the placeholder {{{expr}}} is not an expression") from None
        return str(_value(tree, names, expr, where))

    return PLACEHOLDER.sub(one, text)


def _names_used(key: str) -> set[str]:
    used = set()
    for m in PLACEHOLDER.finditer(key):
        used |= set(re.findall(r"[A-Za-z_]\w*", m.group(1)))
    return used


def expand_columns(columns: dict[str, Any], n_modules: int | None, n_tendons: int, where: str) -> dict[str, Any]:
    """``[columns]`` with every pattern key expanded (see the module docstring).

    Parameters
    ----------
    columns : dict
        The mapping's ``[columns]`` table.
    n_modules : int or None
        ``N``; None where the mapping does not say it (a pattern over modules is then an error).
    n_tendons : int
        Tendons per set ``n``.
    where : str
        The mapping file, named in errors.

    Returns
    -------
    dict
        Spelled-out keys first as given, then each pattern's expansions not spelled out.

    Raises
    ------
    ConfigError
        For an unknown name in a placeholder, a pattern over modules without ``N``, or two patterns
        that expand to one column.
    """
    out = {k: v for k, v in columns.items() if not is_pattern(k)}
    made: dict[str, str] = {}
    for key, spec in columns.items():
        if not is_pattern(key):
            continue
        used = _names_used(key)
        module = sorted(used & {"k", "j", "k0", "j0"})
        tendon = sorted(used & {"i", "i0"})
        unknown = used - {"k", "j", "k0", "j0", "i", "i0"}
        if unknown:
            raise ConfigError(f"{where}: columns.{key}: unknown placeholder name {sorted(unknown)[0]!r} (k, j, i)")
        if module and n_modules is None:
            raise ConfigError(
                f"{where}: columns.{key} expands over the modules, but the mapping does not say how many: "
                "give [meta] n_modules or a robot"
            )
        ks = range(1, n_modules + 1) if module else [1]
        is_ = range(1, n_tendons + 1) if tendon else [1]
        for k, i in itertools.product(ks, is_):
            names = {"k": k, "j": k, "k0": k - 1, "j0": k - 1, "i": i, "i0": i - 1}
            name = fill(key, names, f"{where}: columns.{key}")
            if name in out and name not in made:
                continue  # spelled out: the explicit entry wins
            if name in made:
                raise ConfigError(f"{where}: columns.{key} and columns.{made[name]} both make {name!r}")
            made[name] = key
            out[name] = _fill_spec(spec, names, f"{where}: columns.{key}")
    return out


def _fill_spec(spec: Any, names: dict[str, int], where: str) -> Any:
    """An entry with its ``column`` or ``field`` text filled in (a number or other key is kept)."""
    if isinstance(spec, str):
        return fill(spec, names, where)
    if isinstance(spec, dict):
        return {k: fill(v, names, where) if k in ("column", "field", "topic") and isinstance(v, str) else v
                for k, v in spec.items()}  # fmt: skip
    return spec
