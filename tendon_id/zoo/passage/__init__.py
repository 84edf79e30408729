"""The bench passage family's models (:mod:`tendon_id.zoo.passage.family`): ``passage-capstan`` and its effect blocks.

>>> from tendon_id import zoo
>>> model = zoo.make("passage-capstan", blocks=["stick_slip"])   # doctest: +SKIP
>>> model.fit(bench_train).predict(bench_test).shape              # doctest: +SKIP
(T,)

Importing the package registers every passage block (the sensor blocks are in their own module).
"""

from tendon_id.zoo.passage.blocks import PASSAGE_BLOCKS, PassageBlock
from tendon_id.zoo.passage.inputs import PassageInputs, as_passages
from tendon_id.zoo.passage.model import DIRECTIONS, LAW_PARAMS, PassageCapstan, PassageModel
from tendon_id.zoo.passage.sensor_blocks import ClockSkew, InputCells

__all__ = [
    "ClockSkew",
    "DIRECTIONS",
    "InputCells",
    "LAW_PARAMS",
    "PASSAGE_BLOCKS",
    "PassageBlock",
    "PassageCapstan",
    "PassageInputs",
    "PassageModel",
    "as_passages",
]
