"""What every family's effect blocks declare, and the one kind of registry that holds them.

An effect block is a piece of physics a model is composed of (:doc:`/guide/architecture`): a
contact gate, stick/slip, a viscous friction. Each family has its own base class and its own
stages (where in its forward model a block acts), but every block declares the same things,
which, with the three methods of :class:`EffectBlock`, is all the diagnosis reads:

``name``
    Registry name (what a saved model stores).
``effect``
    The effect it models, the candidate name of the diagnosis (``stick_slip``).
``stage``
    Where it acts in its family's forward model.
``param_names``
    Its free parameters.
``requires``
    Effects it refines: a model needs their blocks too, and the diagnosis tries it once they
    are in.
``needs``
    Optional signals of the data it reads (``position``): where they are missing the
    diagnosis skips it and says why.
``regressor``
    What the effect leaves in a residual, in words.

A family's base block sets ``registry`` to its :class:`BlockRegistry`; every subclass that sets
``name`` registers itself there. The methods :meth:`EffectBlock.neutral` (the parameters' values
that switch the effect off), :meth:`EffectBlock.to_dict` (the block as a report shows it) and
:meth:`EffectBlock.location` (where the effect sits) have defaults a family may override.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any, ClassVar

from tendon_id.checks import check_choice

__all__ = ["BlockRegistry", "EffectBlock"]


class BlockRegistry:
    """A family's effect blocks, by name and by effect (registration order).

    Iterating, ``in`` and ``[effect]`` go by effect, the diagnosis's candidate names.

    Parameters
    ----------
    family : str
        The family's name, for messages.
    """

    def __init__(self, family: str):
        self.family = family
        #: Block class by registry name.
        self.by_name: dict[str, type] = {}
        #: Block class by the effect it models.
        self.by_effect: dict[str, type] = {}

    def add(self, cls: type) -> type:
        """Register ``cls`` under its ``name`` (and its ``effect``, where it has one)."""
        self.by_name[cls.name] = cls
        if cls.effect:
            self.by_effect[cls.effect] = cls
        return cls

    def __iter__(self) -> Iterator[str]:
        return iter(self.by_effect)

    def __contains__(self, effect: object) -> bool:
        return effect in self.by_effect

    def __getitem__(self, effect: str) -> type:
        return self.by_effect[check_choice("effect", effect, self.by_effect, what=f"{self.family} effect")]

    def __len__(self) -> int:
        return len(self.by_effect)

    def lookup(self, name: str) -> type:
        """The block class registered as ``name``, or modelling effect ``name``."""
        cls = self.by_name.get(name) or self.by_effect.get(name)
        if cls is None:
            check_choice("block", name, list(self.by_name) + [e for e in self.by_effect if e not in self.by_name])
        return cls


class EffectBlock:
    """Base of every family's effect blocks: the declarations of the module docstring.

    Subclasses are usually frozen dataclasses; the attributes here are class-level defaults,
    and a family's block may make ``param_names`` a field of its instances (a worn-guide block
    has one parameter per guide it names).
    """

    registry: ClassVar[BlockRegistry | None] = None
    #: Registry name.
    name: ClassVar[str] = ""
    #: The effect it models, or None.
    effect: ClassVar[str | None] = None
    #: Where it acts in its family's forward model.
    stage: ClassVar[str] = ""
    #: Stages a block of this family may act at (checked at registration).
    stages: ClassVar[tuple[str, ...]] = ()
    regressor: ClassVar[str] = ""
    requires: ClassVar[tuple[str, ...]] = ()
    needs: ClassVar[tuple[str, ...]] = ()
    param_names: Any = ()

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if "name" in cls.__dict__ and cls.name and cls.registry is not None:
            if cls.stage not in cls.stages:
                raise TypeError(f"block {cls.name!r} has unknown stage {cls.stage!r}; stages: {', '.join(cls.stages)}")
            cls.registry.add(cls)

    def missing(self, inputs) -> list[str]:
        """The optional signals of :attr:`needs` that ``inputs`` lack (``inputs.has(signal)``)."""
        return [need for need in self.needs if not inputs.has(need)]

    def inert(self, values: dict) -> tuple[str, ...]:
        """Parameters that change nothing at ``values`` (default none): their fitted values mean nothing."""
        return ()

    def neutral(self) -> dict[str, float]:
        """The parameters' values that switch the effect off (default: 0 each)."""
        return {p: 0.0 for p in self.param_names}

    def to_dict(self) -> dict:
        """The block as the diagnosis reports it (default: its name)."""
        return {"block": self.name}

    def location(self) -> str:
        """Where the effect sits, for a block that says (a worn guide); default ``""``, the whole transmission."""
        return ""
