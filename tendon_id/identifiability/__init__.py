"""Identifiability of the transmission from terminal-only data (:doc:`/guide/identifiability`).

Which parameters, and which intermediate tensions, does a terminal-only data set
actually determine?  :func:`analyse` answers for the tied and the per-guide law and
returns one :class:`IdentifiabilityResult`; :func:`tendon_id.report.identifiability.write_report`
turns it into a self-contained HTML page and the JSON of :doc:`/guide/identifiability`.  The study works on
:class:`IdentifiabilityProblem`, the calibration's :class:`tendon_id.calibration.problem.LawProblem`
restricted to the smooth affine-cosine models.
"""

from tendon_id.identifiability.analysis import IdentifiabilityResult, analyse
from tendon_id.identifiability.problem import IdentifiabilityProblem
from tendon_id.identifiability.settings import StudySettings
from tendon_id.identifiability.spectrum import Spectrum, describe_combination, spectrum

#: The study's problem under its former name (kept importable).
LawProblem = IdentifiabilityProblem

__all__ = [
    "IdentifiabilityProblem",
    "IdentifiabilityResult",
    "LawProblem",
    "Spectrum",
    "StudySettings",
    "analyse",
    "describe_combination",
    "spectrum",
]
