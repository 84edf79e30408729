"""Sim-to-real gap diagnosis: where the gap lies, which unmodelled effect causes it, how far it shrinks.

See :doc:`/guide/diagnosis`. Written once for every transmission family (:mod:`tendon_id.family`).

>>> from tendon_id.diagnosis import diagnose        # doctest: +SKIP
>>> result = diagnose(base, train, test)            # doctest: +SKIP
>>> print(result.summary())                         # doctest: +SKIP
"""

from tendon_id.diagnosis.core import check_base, diagnose
from tendon_id.diagnosis.library import Library, candidate_names
from tendon_id.diagnosis.result import VERDICT_KINDS, CandidateResult, DiagnosisResult, Rung, Verdict
from tendon_id.diagnosis.settings import DiagnosisSettings
from tendon_id.diagnosis.splits import Split
from tendon_id.diagnosis.stats import NoiseFloor, difference_floor
from tendon_id.diagnosis.where import Stratum, quartile_masks

__all__ = [
    "VERDICT_KINDS",
    "CandidateResult",
    "DiagnosisResult",
    "DiagnosisSettings",
    "Library",
    "NoiseFloor",
    "Rung",
    "Split",
    "Stratum",
    "Verdict",
    "candidate_names",
    "check_base",
    "diagnose",
    "difference_floor",
    "quartile_masks",
]
