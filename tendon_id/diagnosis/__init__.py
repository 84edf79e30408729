"""Sim-to-real gap diagnosis (DESIGN §13): where the gap lies, which unmodelled effect causes it, how far it shrinks.

>>> from tendon_id.diagnosis import diagnose        # doctest: +SKIP
>>> result = diagnose(base, train, test)            # doctest: +SKIP
>>> print(result.summary())                         # doctest: +SKIP
"""

from tendon_id.diagnosis.core import check_base, diagnose
from tendon_id.diagnosis.library import candidate_names
from tendon_id.diagnosis.oracle import oracle_block, oracle_blocks
from tendon_id.diagnosis.result import VERDICT_KINDS, CandidateResult, DiagnosisResult, Rung, Verdict
from tendon_id.diagnosis.settings import DiagnosisSettings
from tendon_id.diagnosis.where import Stratum

__all__ = [
    "VERDICT_KINDS",
    "CandidateResult",
    "DiagnosisResult",
    "DiagnosisSettings",
    "Rung",
    "Stratum",
    "Verdict",
    "candidate_names",
    "check_base",
    "diagnose",
    "oracle_block",
    "oracle_blocks",
]
