"""Effect blocks: the pieces an analytic transmission model is composed of.

See :mod:`tendon_id.zoo.blocks.base` for the stages and their hooks.  Every block
registers itself in the snake chain's registry :data:`BLOCKS`: by name
(:data:`BLOCK_TYPES`) and by the simulator effect it models (:data:`EFFECT_BLOCKS`,
:doc:`/guide/simulator`), the candidates of the sim-to-real diagnosis (:mod:`tendon_id.diagnosis`).
"""

from __future__ import annotations

import dataclasses
import math

from tendon_id.checks import check_choice
from tendon_id.errors import ConfigError
from tendon_id.zoo.blocks.base import BLOCK_TYPES, BLOCKS, EFFECT_BLOCKS, STAGES, Block, HookContext
from tendon_id.zoo.blocks.drift import FrictionDrift
from tendon_id.zoo.blocks.elastic import ElasticTendon
from tendon_id.zoo.blocks.exponent import ContactGate, GuideWear, VelocityFriction
from tendon_id.zoo.blocks.geometric import RoutingWrap
from tendon_id.zoo.blocks.output import SensorBias, ViscoelasticLag
from tendon_id.zoo.blocks.sensors import ActuatorCells, ClockSkew, LoadCellDynamics
from tendon_id.zoo.blocks.slip import BendingStiffness, Hysteresis, SmoothEdge
from tendon_id.zoo.blocks.start import StartState
from tendon_id.zoo.blocks.wrap import PerTendonWrap

__all__ = [
    "BLOCKS",
    "BLOCK_TYPES",
    "EFFECT_BLOCKS",
    "STAGES",
    "ActuatorCells",
    "BendingStiffness",
    "Block",
    "ClockSkew",
    "ContactGate",
    "ElasticTendon",
    "FrictionDrift",
    "GuideWear",
    "HookContext",
    "Hysteresis",
    "LoadCellDynamics",
    "PerTendonWrap",
    "RoutingWrap",
    "SensorBias",
    "SmoothEdge",
    "StartState",
    "VelocityFriction",
    "ViscoelasticLag",
    "as_block",
    "block_from_dict",
    "compose",
]


def block_from_dict(d: dict) -> Block:
    """Rebuild a block from :meth:`Block.to_dict`."""
    d = dict(d)
    name = check_choice("block", d.pop("block", None), BLOCK_TYPES)
    cls = BLOCK_TYPES[name]
    from_dict = getattr(cls, "from_dict", None)
    try:
        block = from_dict(d) if from_dict is not None else cls(**d)
    except TypeError as exc:
        raise ConfigError(f"block {name!r}: {exc}") from None
    defaults = {f.name: f.default for f in dataclasses.fields(block)} if dataclasses.is_dataclass(block) else {}
    for p in block.param_names:  # a hand-edited file's value: a finite number, or None (the robot's value)
        v = getattr(block, p, None)
        if v is None and defaults.get(p, None) is not None:  # only a block whose default is None reads None
            raise ConfigError(f"block {name!r}: {p} must be a finite number, got None", param="blocks")
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)):
            raise ConfigError(f"block {name!r}: {p} must be a finite number, got {v!r}", param="blocks")
    return block


def as_block(b: Block | str | dict) -> Block:
    """A block from a block, its name or its effect's name (default settings), or :meth:`Block.to_dict`'s dict."""
    if isinstance(b, Block):
        return b
    if isinstance(b, str):
        return BLOCKS.lookup(b)()
    if isinstance(b, dict):
        return block_from_dict(b)
    raise ConfigError(f"a block must be a Block, a block name or a dict, got {b!r}")


def compose(blocks) -> tuple[Block, ...]:
    """The blocks of one model (blocks, names or dicts), checked to compose.

    A block needs the blocks of the effects it refines; a model has at most one propagation block
    (hysteresis) and one that refines it, at most one wrap block and one start block, no block
    acting guide by guide on edges or outputs beside a whole-chain block (:attr:`Block.whole_chain`),
    and each block once (so one routing block).

    Raises
    ------
    ConfigError
        Naming ``blocks``, for a composition that does not hold.
    """
    out = tuple(as_block(b) for b in blocks)
    effects = {b.effect for b in out}
    for b in out:
        missing = [r for r in b.requires if r not in effects]
        if missing:
            raise ConfigError(
                f"the {b.name} block refines {', '.join(missing)}: add that effect's block too", param="blocks"
            )
    propagate = [b for b in out if b.stage == "propagate"]
    if sum(not b.requires for b in propagate) > 1 or sum(bool(b.requires) for b in propagate) > 1:
        raise ConfigError(
            "a model can have at most one propagation block (hysteresis), and one that refines it", param="blocks"
        )
    if any(b.whole_chain for b in out) and any(b.stage in ("edges", "guide_output") for b in out):
        whole = ", ".join(b.name for b in out if b.whole_chain)
        per_guide = ", ".join(b.name for b in out if b.stage in ("edges", "guide_output"))
        raise ConfigError(
            f"{whole} acts on every guide of a tendon at once; it does not compose with blocks that act on one "
            f"guide's edges or output ({per_guide})",
            param="blocks",
        )
    if sum(b.stage == "start" for b in out) > 1:
        raise ConfigError("a model can have at most one start block", param="blocks")
    step = next((b for b in propagate if b.requires), propagate[0] if propagate else None)
    start = next((b for b in out if b.stage == "start"), None)
    if start is not None and (step is None or type(step).propagate_series is Block.propagate_series):
        raise ConfigError(
            f"{start.name} sets the state the pass over the whole chain starts from; the "
            f"{step.name if step is not None else 'model'}'s step has no such pass",
            param="blocks",
        )
    if sum(b.stage == "wrap" for b in out) > 1:
        raise ConfigError("a model can have at most one wrap block", param="blocks")
    names = [b.name for b in out]
    if len(set(names)) != len(names):
        raise ConfigError(f"each block may appear once, got {names}", param="blocks")
    return out
