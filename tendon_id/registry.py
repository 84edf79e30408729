"""Tables of names whose entries are imported on first use: the zoo's models, the families, the benchmarks.

A built-in entry is listed as ``"module:attribute"`` and imported the first time it is asked
for, so that listing a table imports nothing: ``import tendon_id.zoo`` loads no torch, ``--help``
answers at once, and the code written once names a family without importing it.
"""

from __future__ import annotations

import importlib
from typing import Any

from tendon_id.checks import check_choice

__all__ = ["Registry", "resolve"]


def resolve(path: str) -> Any:
    """The object ``"module:attribute"`` names, importing its module."""
    module, _, attr = path.partition(":")
    return getattr(importlib.import_module(module), attr)


class Registry:
    """Names to objects, in registration order; built-in entries are resolved on first use.

    Parameters
    ----------
    what : str
        What an entry is, for messages (``"model"``, ``"transmission family"``).
    builtin : dict
        The built-in entries, ``name -> "module:attribute"``.
    """

    def __init__(self, what: str, builtin: dict[str, str]):
        self.what = what
        self.builtin = dict(builtin)
        self._entries: dict[str, Any] = dict(builtin)
        self._replaced: set[str] = set()  # built-in names registered anew

    def register(self, name: str, obj: Any) -> Any:
        """Add ``obj`` as ``name`` (in place of a built-in one of that name); returns it."""
        self._entries[name] = obj
        if name in self.builtin:
            self._replaced.add(name)
        return obj

    def unregister(self, name: str) -> None:
        """Remove ``name`` (a built-in entry comes back as it was)."""
        check_choice("name", name, self._entries, what=self.what)
        if name in self.builtin:
            self._entries[name] = self.builtin[name]
            self._replaced.discard(name)
        else:
            del self._entries[name]

    def names(self) -> list[str]:
        """The registered names, in order (imports nothing)."""
        return list(self._entries)

    def get(self, name: str, param: str = "name") -> Any:
        """The entry ``name`` (ConfigError naming ``param`` and the known names otherwise), imported on first use."""
        entry = self._entries[check_choice(param, name, self._entries, what=self.what)]
        if isinstance(entry, str):
            entry = self._entries[name] = resolve(entry)
        return entry

    def builtin_module(self, name: str) -> str | None:
        """The module a built-in entry lives in, without importing it (None for a registered one)."""
        if name not in self.builtin or name in self._replaced:
            return None
        return self.builtin[name].partition(":")[0]
