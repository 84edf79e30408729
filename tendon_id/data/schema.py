"""Column names and metadata keys of a recording (:doc:`/guide/data`).

Everything here is a name or a constant: which columns a recording of ``N`` modules has, in
which order, and which metadata keys it carries. Checking values against these names is the
job of :mod:`tendon_id.data.normalise` (metadata) and :mod:`tendon_id.data.validation` (data).
"""

from __future__ import annotations

import re
from collections.abc import Sequence

__all__ = [
    "SCHEMA_VERSION",
    "META_ORDER",
    "AXES",
    "TENDONS",
    "DEFAULT_TENDONS",
    "THETA_RE",
    "TENSION_RE",
    "column_names",
    "theta_columns",
    "act_columns",
    "joint_columns",
    "truth_columns",
    "required_columns",
    "hidden_truth_columns",
    "intermediate_joints",
    "module_index",
    "infer_n_modules",
    "infer_n_tendons",
    "tendon_count",
]

#: Version of the column and metadata schema written by this package.
SCHEMA_VERSION = 1

#: Known metadata keys, in the order a recording keeps them (unknown keys follow).
META_ORDER = ("schema_version", "n_modules", "sample_rate_hz", "protocol", "robot", "recipe", "effects", "seed")

#: Axes of the joint angles ``theta_{k}_x``, ``theta_{k}_y``.
AXES = ("x", "y")

#: Tendons per set where a recording says nothing (the paper robot's three; ``robot.n_tendons`` sets it).
DEFAULT_TENDONS = 3
#: Tendon numbers ``i`` of the tension columns of a 3-tendon robot.
TENDONS = tuple(range(1, DEFAULT_TENDONS + 1))

# Module-numbered columns. Indices are matched without leading zeros so that ``theta_01_x`` is
# an extra column rather than silently taken for module 1.

#: Joint-angle column: group 1 is the module ``k``, group 2 the axis.
THETA_RE = re.compile(r"^theta_(0|[1-9][0-9]*)_([xy])$")

#: Tension column: group 1 is the side (``act`` or ``joint``), group 2 the module, group 3 the tendon.
TENSION_RE = re.compile(r"^tension_(act|joint)_(0|[1-9][0-9]*)_(0|[1-9][0-9]*)$")


def theta_columns(n: int) -> list[str]:
    """Joint-angle columns ``theta_{k}_x, theta_{k}_y``, ``k = 1..n`` (k-major)."""
    return [f"theta_{k}_{a}" for k in range(1, n + 1) for a in AXES]


def act_columns(n: int, n_tendons: int = DEFAULT_TENDONS) -> list[str]:
    """Actuator-side tension columns ``tension_act_{j}_{i}``, ``j = 1..n``, ``i = 1..n_tendons`` (j-major)."""
    return [f"tension_act_{j}_{i}" for j in range(1, n + 1) for i in range(1, n_tendons + 1)]


def joint_columns(j: int, n_tendons: int = DEFAULT_TENDONS) -> list[str]:
    """Joint-side tension columns ``tension_joint_{j}_{i}`` of joint ``j``, ``i = 1..n_tendons``."""
    return [f"tension_joint_{j}_{i}" for i in range(1, n_tendons + 1)]


def truth_columns(n: int, n_tendons: int = DEFAULT_TENDONS) -> list[str]:
    """Intermediate joint-side truth columns, ``j = 1..N-1`` (j-major)."""
    return [c for j in range(1, n) for c in joint_columns(j, n_tendons)]


def column_names(n_modules: int, *, truth: bool = True, n_tendons: int = DEFAULT_TENDONS) -> list[str]:
    """Canonical column names of a recording, in canonical order.

    Parameters
    ----------
    n_modules : int
        Number of modules ``N`` (>= 1).
    truth : bool, default True
        Include the intermediate joint-side truth columns ``tension_joint_{j}_{i}``, ``j < N``.
        The terminal columns ``tension_joint_{N}_{i}`` are always included.
    n_tendons : int, default 3
        Tendons per set ``n`` (``i = 1..n``).

    Returns
    -------
    list of str
        ``trajectory``, ``t``, the angles ``theta_{k}_x, theta_{k}_y`` (k-major), the actuator
        tensions ``tension_act_{j}_{i}`` (j-major), then the joint-side tensions
        ``tension_joint_{j}_{i}`` (j-major; only ``j = N`` when ``truth`` is False).
    """
    n = int(n_modules)
    if n < 1:
        raise ValueError(f"n_modules must be >= 1, got {n_modules!r}")
    joints = list(range(1, n + 1)) if truth else [n]
    tendons = act_columns(n, n_tendons) + [c for j in joints for c in joint_columns(j, n_tendons)]
    return ["trajectory", "t"] + theta_columns(n) + tendons


def required_columns(n: int, n_tendons: int = DEFAULT_TENDONS) -> list[str]:
    """Columns every recording of ``n`` modules must have: all but the intermediate truth."""
    return column_names(n, truth=False, n_tendons=n_tendons)


def hidden_truth_columns(columns: Sequence[str], n: int) -> list[str]:
    """The intermediate truth columns ``tension_joint_{j}_{i}``, ``j < n``, among ``columns``.

    Unlike :func:`truth_columns` this matches any tendon number, so a fitting view cannot
    leak truth through an oddly numbered column.
    """
    return [c for c in columns if (m := TENSION_RE.match(c)) and m.group(1) == "joint" and int(m.group(2)) < n]


def intermediate_joints(columns: Sequence[str], n: int, n_tendons: int = DEFAULT_TENDONS) -> list[int]:
    """Joints ``j < n`` whose truth columns (one per tendon) are all among ``columns``."""
    return [j for j in range(1, n) if all(c in columns for c in joint_columns(j, n_tendons))]


def module_index(column: str) -> int | None:
    """Module index a schema column refers to, or None for a column outside the schema."""
    m = THETA_RE.match(column)
    if m:
        return int(m.group(1))
    m = TENSION_RE.match(column)
    if m:
        return int(m.group(2))
    return None


def infer_n_modules(columns: Sequence[str]) -> tuple[int | None, str | None]:
    """Largest module index among the schema columns, and the first column that carries it."""
    best, best_col = None, None
    for c in columns:
        k = module_index(c)
        if k is not None and (best is None or k > best):
            best, best_col = k, c
    return best, best_col


def infer_n_tendons(columns: Sequence[str]) -> int | None:
    """Largest tendon index among the actuator-side tension columns (None where there is none)."""
    found = [int(m.group(3)) for c in columns if (m := TENSION_RE.match(c)) and m.group(1) == "act"]
    return max(found) if found else None


def tendon_count(robot: dict | None, columns: Sequence[str]) -> int:
    """Tendons per set of a recording: its ``robot.n_tendons``, else its columns', else 3."""
    given = (robot or {}).get("n_tendons")
    if given is not None:
        return int(given)
    return infer_n_tendons(columns) or DEFAULT_TENDONS
