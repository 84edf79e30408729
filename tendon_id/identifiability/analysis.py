"""``analyse``: the whole identifiability study of one data set, as one result object (:doc:`/guide/identifiability`).

The study compares the tied law (one ``(A_i, B_i)`` per tendon, the paper's) with the
per-guide law (one per guide and tendon) on the data's terminal labels only:
structure (rank, Fisher spectrum, named directions), profile likelihoods, posterior
widths and correlations, excitation, the intermediate-tension ambiguity band, and
advice on what to measure next.  Intermediate truth, where the data has it, is used
only to score the bands and the advice, never to fit.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration.posterior import sample_posterior
from tendon_id.data import Recording
from tendon_id.data.io import release_arrow_memory
from tendon_id.errors import ConfigError
from tendon_id.identifiability.advice import excite_joints, instrument_scores, judge_advice, measure_advice
from tendon_id.identifiability.band import ambiguity_band, band_frames
from tendon_id.identifiability.excitation import excitation
from tendon_id.identifiability.learned import learned_comparison
from tendon_id.identifiability.problem import TYINGS, IdentifiabilityProblem
from tendon_id.identifiability.settings import MODELS, StudySettings
from tendon_id.identifiability.study import TyingStudy, study_tying
from tendon_id.identifiability.summary import lead_sentences
from tendon_id.identifiability.truth import data_name, truth_law
from tendon_id.progress import progress_bar
from tendon_id.zoo.capstan import CapstanModel
from tendon_id.zoo.inputs import TransmissionInputs, as_recordings
from tendon_id.zoo.registry import make

# Re-exported: these lived here before the study was split into modules.
__all__ = [
    "MISSPECIFIED_RATIO",
    "MODELS",
    "IdentifiabilityResult",
    "StudySettings",
    "TyingStudy",
    "analyse",
    "learned_comparison",
    "measure_advice",
]

#: Residual noise above this multiple of the load cells' nominal noise means the model is misspecified.
MISSPECIFIED_RATIO = 1.5


@dataclass
class IdentifiabilityResult:
    """The single result of :func:`analyse`; :meth:`to_dict` gives the JSON of :doc:`/guide/identifiability` (a floor).

    ``truth`` holds the data's intermediate joint-side truth (T, N, n) where present; it
    scores the bands and the advice and is never used to fit.  ``truth_law`` is the simulator's
    friction law where the recording's metadata carries it (:func:`~tendon_id.identifiability.truth.truth_law`),
    shown beside the fitted one and never fitted either.
    """

    settings: StudySettings
    source: str | None
    model_name: str
    protocol: str | None
    n_frames: int
    n_modules: int
    noise_n: float
    studies: dict[str, TyingStudy]
    excitation: list[dict]
    instrument: list[dict]
    instrument_joint: int
    excite: list[int]
    coverage: dict[str, NDArray] | None
    advice_check: list[dict] | None
    emcee: dict | None
    learned: dict | None
    seconds: float
    truth: NDArray | None = field(default=None, repr=False)
    name: str = "unnamed data"
    truth_law: dict | None = None
    advice_baseline: dict | None = None

    @property
    def advice_verdict(self) -> dict:
        """Whether the check against the truth confirms the linearised advice (:func:`~.advice.judge_advice`)."""
        return judge_advice(self.instrument, self.advice_check, self.advice_baseline)

    @property
    def misspecification(self) -> dict:
        """Residual noise against the load cells' nominal noise, per tendon (the best tying's)."""
        best = np.minimum(self.studies["tied"].sigma, self.studies["per-guide"].sigma)
        ratio = [float(s / self.noise_n) for s in best]
        mis = bool(max(ratio) > MISSPECIFIED_RATIO)
        return {
            "residual_sigma_n": [float(s) for s in best],
            "nominal_noise_n": self.noise_n,
            "ratio": ratio,
            "threshold_ratio": MISSPECIFIED_RATIO,
            "misspecified": mis,
            # How the study's numbers read: a misspecified structure's estimates describe its best fit only.
            "numbers_describe": "the misspecified fit, not the robot" if mis else "the robot, as far as the data go",
        }

    def to_dict(self) -> dict:
        """The study as JSON-able data: ``identifiability --json``'s shape, and more (:doc:`/guide/identifiability`)."""
        tied, per = self.studies["tied"], self.studies["per-guide"]
        cov = self.coverage
        bands = {
            "tied_width_mean": tied.band.mean_width(),
            "per_guide_width_mean": per.band.mean_width(),
            "tied_width_per_joint": [float(x) for x in tied.band.per_joint_width()],
            "per_guide_width_per_joint": [float(x) for x in per.band.per_joint_width()],
            "truth_coverage": None if cov is None else float(np.mean(cov["tied"][1:-1])),
            "truth_coverage_min_joint": None if cov is None else float(np.min(cov["tied"][1:-1])),
            "tied_coverage_per_joint": None if cov is None else [float(x) for x in cov["tied"]],
            "per_guide_truth_coverage": None if cov is None else float(np.mean(cov["per-guide"][1:-1])),
            "coverage_joints": "intermediate joints 2..N-1 (joint N's 'truth' is the measured label itself)",
            "per_guide_coverage_per_joint": None if cov is None else [float(x) for x in cov["per-guide"]],
            "frames": int(len(tied.band.frames)),
            "quantiles": [2.5, 97.5],
        }
        return {
            "name": self.name,
            "summary": lead_sentences(self),
            "source": self.source,
            "protocol": self.protocol,
            "frames": self.n_frames,
            "model": self.model_name,
            "tied": tied.to_dict(),
            "per_guide": per.to_dict(),
            "bands": bands,
            "misspecification": self.misspecification,
            "truth": self.truth_law,
            "excitation": self.excitation,
            "advice": {
                # The linearised (D-optimal) joint; whether the check confirms it is in "verdict".
                "instrument_joint": self.instrument_joint,
                "excite_joints": self.excite,
                "candidates": self.instrument,
                "check": self.advice_check,
                "check_baseline": self.advice_baseline,
                "verdict": self.advice_verdict,
            },
            "emcee": self.emcee,
            "learned": self.learned,
            "seconds": self.seconds,
        }


def _base_model(name: str, views: Sequence[Recording]) -> CapstanModel:
    """The calibrated tied model the study is built on (``auto``: the smooth one that fits best)."""
    names = ("capstan-simple", "capstan-contact") if name == "auto" else (name,)
    fitted = [make(n).fit(views) for n in names]
    return min(fitted, key=lambda m: m.calibration_["loss"])


def _noise_of(recs: Sequence[Recording], noise_n: float | None) -> float:
    if noise_n is not None:
        return float(noise_n)
    sensors = recs[0].meta.get("sensors") or {}
    noise = float(sensors.get("noise_n", 1.0))  # a finite number >= 0: checked as the file was read
    if not noise > 0:
        raise ConfigError(
            f"{recs[0].source or 'the recording'}: metadata sensors.noise_n is {noise:g} N; the study weights the "
            "data by the load cells' noise, so give a positive one with --noise-n",
            param="noise_n",
        )
    return noise


def analyse(
    data: Recording | Sequence[Recording],
    settings: StudySettings | None = None,
    *,
    learned: bool = False,
    learned_seeds: int = 3,
    progress: bool | None = None,
) -> IdentifiabilityResult:
    """Identifiability study of terminal-only data (see the module docstring).

    Parameters
    ----------
    data : Recording or sequence of Recording
    settings : StudySettings, optional
    learned : bool
        Also train tied and per-guide PG-CHTC (fast preset) over ``learned_seeds`` seeds
        (slow: minutes).
    progress : bool, optional
        Progress bar (default: on a terminal).
    """
    settings = settings or StudySettings()
    t0 = time.perf_counter()
    recs = as_recordings(data)
    views = [r.fitting_view() for r in recs]  # the analysis never reads intermediate truth
    truth = np.concatenate([r.joint_truth for r in recs]) if all(r.has_truth for r in recs) else None
    noise = _noise_of(recs, settings.noise_n)
    steps = (
        ["structure, profiles and posterior (tied)", "structure, profiles and posterior (per-guide)", "bands", "advice"]
        + (["emcee"] if settings.emcee else [])
        + (["learned cascade"] if learned else [])
    )
    bar = progress_bar(steps, desc="identifiability", enable=progress)
    it = iter(bar)

    base = _base_model(settings.model, views)
    inputs = TransmissionInputs.from_recordings(views, base.geometry_)
    source, protocol, name, law = recs[0].source, recs[0].protocol, data_name(recs), truth_law(recs)
    if not (settings.emcee or learned):
        data = recs = views = None  # recordings handed over (the CLI's) are freed: the studies read the arrays
        release_arrow_memory()  # their text lived in Arrow's allocator, which keeps what is freed until asked
    studies: dict[str, TyingStudy] = {}
    problem = None
    for tying in TYINGS:
        next(it, None)
        # One design for both tyings: its arrays are the data's and the structure's, not the tying's.
        problem = (
            IdentifiabilityProblem.from_model(base, inputs, tying, noise)
            if problem is None
            else dataclasses.replace(problem, tying=tying)
        )
        studies[tying] = study_tying(problem, settings, settings.seed)
    next(it, None)
    frames = band_frames(inputs.n_frames, settings.band_frames, settings.seed)
    for st in studies.values():
        st.band = ambiguity_band(st.problem, st.draws, frames, seed=settings.seed)
    coverage = None
    if truth is not None:
        coverage = {t: st.band.coverage(truth) for t, st in studies.items()}

    next(it, None)
    per = studies["per-guide"]
    wrap = base.backbone(inputs, base.block_params_)  # with the fitted routing wrap
    # In contact where the gate leaves any of the wrap to friction (the dead zone scales it, the hard gate cuts it).
    gate = (per.problem.guide_design[..., 1] > 0).astype(float)
    cover = excitation(wrap, gate if base.alpha_c_ is not None else None)
    scores = instrument_scores(per.problem, per.theta, per.sigma, frames)
    best = max(scores, key=lambda s: s["log_det"])["joint"]
    excite = excite_joints(per.mu0_sd())
    check, baseline = None, None
    if truth is not None and settings.check_advice:
        check = measure_advice(per, truth, frames, settings)
        baseline = per.band.scores(truth)

    emcee_summary = None
    if settings.emcee:
        next(it, None)
        emcee_summary = _emcee_tied(base, views, settings)
    learned_summary = None
    if learned:
        next(it, None)
        learned_summary = learned_comparison(views, truth, seeds=learned_seeds, progress=progress)
    for _ in it:
        pass
    return IdentifiabilityResult(
        settings=settings,
        source=None if source is None else str(source),
        model_name=base.name,
        protocol=protocol,
        n_frames=inputs.n_frames,
        n_modules=inputs.n_modules,
        noise_n=noise,
        studies=studies,
        excitation=cover,
        instrument=scores,
        instrument_joint=int(best),
        excite=excite,
        coverage=coverage,
        advice_check=check,
        emcee=emcee_summary,
        learned=learned_summary,
        seconds=time.perf_counter() - t0,
        truth=truth,
        name=name,
        truth_law=law,
        advice_baseline=baseline,
    )


def _emcee_tied(base: CapstanModel, views: Sequence[Recording], settings: StudySettings) -> dict:
    """Tied posterior with emcee (:mod:`tendon_id.calibration.posterior`): widths, A–B correlations, ESS, R-hat."""
    # Without the encoder marginalisation, so that it targets the same posterior as the hit-and-run draws.
    post = sample_posterior(
        base, views, target_ess=400.0, max_steps=20000, seed=settings.seed, encoder_bits=None, progress=False
    )
    A, B = post.law_samples()
    corr = [float(np.corrcoef(A[:, 0, i], B[:, 0, i])[0, 1]) for i in range(A.shape[2])]
    mu0_sd = [float(x) for x in (A + B)[:, 0].std(axis=0, ddof=1)]
    return {
        "parameters": post.statistics(),
        "corr_A_B": corr,
        "mu0_sd": mu0_sd,
        "tau": float(np.max(post.tau)),
        "seconds": post.seconds,
        "acceptance": post.acceptance,
    }
