"""The transmission family: the seam every generic part of tendon-id reaches a kind of transmission through.

>>> from tendon_id.family import family_of           # doctest: +SKIP
>>> family_of(model).residual(model, inputs)         # doctest: +SKIP

See :mod:`tendon_id.family.protocol` for what a family supplies and :doc:`/guide/architecture`
for where it sits.
"""

from tendon_id.family.blocks import BlockRegistry, EffectBlock
from tendon_id.family.fit import Fit
from tendon_id.family.inputs import FrameInputs
from tendon_id.family.protocol import Family
from tendon_id.family.registry import (
    family_named,
    family_names,
    family_of,
    get_family,
    register_family,
    unregister_family,
)

__all__ = [
    "BlockRegistry",
    "EffectBlock",
    "Family",
    "Fit",
    "FrameInputs",
    "family_named",
    "family_names",
    "family_of",
    "get_family",
    "register_family",
    "unregister_family",
]
