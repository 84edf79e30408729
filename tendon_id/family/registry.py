"""The families by name: the built-in ones listed by where they live, imported on first use.

Like the zoo's registry, the table names ``"module:attribute"`` instead of importing, so that
asking for one family imports only its own modules, and no module of the code written once has an
import of a family's module (``python .ci/import_graph.py`` checks it).
"""

from __future__ import annotations

from tendon_id.family.protocol import Family
from tendon_id.registry import Registry

__all__ = [
    "DEFAULT_MAPPED",
    "family_named",
    "family_names",
    "family_of",
    "family_of_meta",
    "get_family",
    "register_family",
    "unregister_family",
]

#: Built-in families: name -> ``"module:attribute"`` of the :class:`Family` instance.
BUILTIN: dict[str, str] = {
    "snake": "tendon_id.zoo.snake.family:SNAKE",
    "passage": "tendon_id.zoo.passage.family:PASSAGE",
}
#: The family a mapping file (``tendon-id ... --mapping``) describes when it names none: mappings
#: were made for a bench's own files first.
DEFAULT_MAPPED = "passage"

_FAMILIES = Registry("transmission family", BUILTIN)


def register_family(family: Family) -> Family:
    """Add ``family`` under its name (a new one, or in place of a built-in); returns it."""
    if not isinstance(family, Family):
        raise TypeError(f"a family must be a Family instance, got {type(family).__name__}")
    return _FAMILIES.register(family.name, family)


def unregister_family(name: str) -> None:
    """Remove the family registered as ``name`` (a built-in one comes back as it was)."""
    _FAMILIES.unregister(name)


def family_names() -> list[str]:
    """The registered families' names (imports none)."""
    return _FAMILIES.names()


def get_family(name: str) -> Family:
    """The family registered as ``name``, importing its module on first use."""
    return _FAMILIES.get(name, "family")


class family_named:  # noqa: N801 - used like a decorator-free property, in lower case as ``property`` is
    """A class attribute that is the family registered as ``name``, looked up on use.

    A model or recording class says ``family = family_named("snake")``: its module then imports
    no family module, and the family's module may import it.
    """

    def __init__(self, name: str):
        self.name = name

    def __get__(self, obj, cls=None) -> Family:
        return get_family(self.name)


def family_of(obj) -> Family:
    """The family of a model or a recording (its ``family`` attribute), class or instance."""
    family = getattr(obj, "family", None)
    if not isinstance(family, Family):
        what = getattr(obj, "name", None) or getattr(obj, "__name__", None) or type(obj).__name__
        raise TypeError(f"{what} belongs to no transmission family (it has no 'family')")
    return family


def family_of_meta(meta: dict | None) -> Family:
    """The family whose recording a file's metadata describes: its ``kind``, else the snake chain's.

    Files of the snake chain's schema carry no ``kind``: they were written before there was more
    than one family.
    """
    return get_family((meta or {}).get("kind") or "snake")
