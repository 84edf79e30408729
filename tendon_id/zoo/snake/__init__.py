"""The snake chain family's parts (:mod:`tendon_id.zoo.snake.family`): its refit, diagnosis and contract checks.

Its models, blocks and inputs live in the zoo beside (:mod:`tendon_id.zoo.capstan`,
:mod:`tendon_id.zoo.blocks`, :mod:`tendon_id.zoo.inputs`), its law's calibration in
:mod:`tendon_id.calibration`.
"""
