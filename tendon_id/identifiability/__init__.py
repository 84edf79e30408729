"""Identifiability of the transmission from terminal-only data (DESIGN §12).

Which parameters, and which intermediate tensions, does a terminal-only data set
actually determine?  :func:`analyse` answers for the tied and the per-guide law and
returns one :class:`IdentifiabilityResult`; :func:`tendon_id.report.identifiability.write_report`
turns it into a self-contained HTML page and the JSON of DESIGN §10.
"""

from tendon_id.identifiability.analysis import IdentifiabilityResult, StudySettings, analyse
from tendon_id.identifiability.problem import LawProblem
from tendon_id.identifiability.spectrum import Spectrum, describe_combination, spectrum

__all__ = ["IdentifiabilityResult", "LawProblem", "Spectrum", "StudySettings", "analyse", "describe_combination", "spectrum"]
