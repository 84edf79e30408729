"""Optional extras: what each needs, read from the installed package's metadata, checked before work starts.

``pyproject.toml`` is the one list of the extras; this module asks the installed
distribution which packages an extra pulls in, so the check cannot drift from it.
"""

from __future__ import annotations

import importlib.metadata as metadata
import re

from tendon_id.errors import TendonIdError

DISTRIBUTION = "tendon-id"


class MissingExtraError(TendonIdError, ImportError):
    """An optional extra that a command needs is not installed (the CLI exits with code 2)."""


def extra_requirements(extra: str, distribution: str = DISTRIBUTION) -> list[str]:
    """Names of the packages that ``pip install 'tendon-id[extra]'`` adds.

    Empty when the package is not installed (a source checkout on ``PYTHONPATH``), where
    there is no metadata to read.
    """
    try:
        requires = metadata.requires(distribution) or []
    except metadata.PackageNotFoundError:
        return []
    marker = re.compile(r"""extra\s*==\s*["']""" + re.escape(extra) + r"""["']""")
    names = []
    for req in requires:
        spec, _, env = req.partition(";")
        if marker.search(env):
            names.append(re.match(r"[A-Za-z0-9_.\-]+", spec.strip()).group(0))
    return names


def require_extra(extra: str, purpose: str, distribution: str = DISTRIBUTION) -> None:
    """Raise :class:`MissingExtraError` naming the pip command if ``extra`` is not fully installed.

    Parameters
    ----------
    extra : str
        The extra's name in ``pyproject.toml`` (e.g. ``"posterior"``).
    purpose : str
        What needs it, for the message (e.g. ``"--posterior (its corner plot)"``).
    """
    missing = []
    for name in extra_requirements(extra, distribution):
        try:
            metadata.distribution(name)
        except metadata.PackageNotFoundError:
            missing.append(name)
    if missing:
        raise MissingExtraError(
            f"{purpose} needs {', '.join(missing)}, from the optional extra '{extra}'; "
            f"install it with: pip install '{distribution}[{extra}]'"
        )
