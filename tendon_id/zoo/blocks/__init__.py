"""Effect blocks: the pieces an analytic transmission model is composed of.

See :mod:`tendon_id.zoo.blocks.base` for the stages and their hooks.  Every block
registers itself by name in :data:`BLOCK_TYPES`; :data:`EFFECT_BLOCKS` maps each
simulator effect (DESIGN §5) to the block that models it, the candidates of the
sim-to-real diagnosis (:mod:`tendon_id.diagnosis`).
"""

from __future__ import annotations

from tendon_id.errors import ConfigError
from tendon_id.zoo.blocks.base import BLOCK_TYPES, EFFECT_BLOCKS, STAGES, Block, Passage
from tendon_id.zoo.blocks.exponent import ContactGate, GuideWear, VelocityFriction
from tendon_id.zoo.blocks.output import SensorBias, ViscoelasticLag
from tendon_id.zoo.blocks.slip import BendingStiffness, Hysteresis, SmoothEdge
from tendon_id.zoo.blocks.wrap import PerTendonWrap

__all__ = [
    "BLOCK_TYPES",
    "EFFECT_BLOCKS",
    "STAGES",
    "BendingStiffness",
    "Block",
    "ContactGate",
    "GuideWear",
    "Hysteresis",
    "Passage",
    "PerTendonWrap",
    "SensorBias",
    "SmoothEdge",
    "VelocityFriction",
    "ViscoelasticLag",
    "as_block",
    "block_from_dict",
]


def block_from_dict(d: dict) -> Block:
    """Rebuild a block from :meth:`Block.to_dict`."""
    d = dict(d)
    name = d.pop("block", None)
    if name not in BLOCK_TYPES:
        raise ConfigError(f"unknown block {name!r}; known blocks: {', '.join(BLOCK_TYPES)}")
    cls = BLOCK_TYPES[name]
    from_dict = getattr(cls, "from_dict", None)
    try:
        return from_dict(d) if from_dict is not None else cls(**d)
    except TypeError as exc:
        raise ConfigError(f"block {name!r}: {exc}") from None


def as_block(b: Block | str | dict) -> Block:
    """A block from a block, its name or its effect's name (default settings), or :meth:`Block.to_dict`'s dict."""
    if isinstance(b, Block):
        return b
    if isinstance(b, str):
        cls = BLOCK_TYPES.get(b) or EFFECT_BLOCKS.get(b)
        if cls is None:
            raise ConfigError(
                f"unknown block {b!r}; known blocks: {', '.join(BLOCK_TYPES)} (or effects: {', '.join(EFFECT_BLOCKS)})"
            )
        return cls()
    if isinstance(b, dict):
        return block_from_dict(b)
    raise ConfigError(f"a block must be a Block, a block name or a dict, got {b!r}")
