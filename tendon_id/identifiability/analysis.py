"""``analyse``: the whole identifiability study of one data set, as one result object (DESIGN §12).

The study compares the tied law (one ``(A_i, B_i)`` per tendon, the paper's) with the
per-guide law (one per guide and tendon) on the data's terminal labels only:
structure (rank, Fisher spectrum, named directions), profile likelihoods, posterior
widths and correlations, excitation, the intermediate-tension ambiguity band, and
advice on what to measure next.  Intermediate truth, where the data has it, is used
only to score the bands and the advice, never to fit.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration import _fit_quadratic
from tendon_id.data import Recording
from tendon_id.errors import ConfigError
from tendon_id.identifiability.advice import excite_joints, instrument_scores
from tendon_id.identifiability.band import Band, ambiguity_band, band_frames
from tendon_id.identifiability.excitation import excitation
from tendon_id.identifiability.problem import TYINGS, LawProblem
from tendon_id.identifiability.profile import Profile, profile
from tendon_id.identifiability.sampler import dispersed_starts, hit_and_run, split_rhat
from tendon_id.identifiability.spectrum import Spectrum, spectrum
from tendon_id.progress import progress_bar
from tendon_id.zoo.inputs import TransmissionInputs, as_recordings

#: Residual noise above this multiple of the load cells' nominal noise means the model is misspecified.
MISSPECIFIED_RATIO = 1.5
#: Models the study accepts (``auto`` picks between the two smooth ones).
MODELS = ("auto", "capstan-contact", "capstan-simple")


@dataclass(frozen=True)
class StudySettings:
    """Settings of :func:`analyse` (validated on creation).

    Attributes
    ----------
    model : str
        Smooth capstan model whose structure is analysed: ``capstan-contact``, ``capstan-simple``,
        or ``auto`` (both are calibrated, tied, and the one with the smaller terminal residual is kept;
        they have the same number of parameters).
    noise_n : float or None
        Load-cell noise [N]; None reads the recording's ``sensors.noise_n`` (else 1 N).
    band_frames : int
        Frames the band is evaluated on (a seeded subset of larger data).
    n_chains, n_steps, thin : int
        Hit-and-run sampler (see :mod:`~tendon_id.identifiability.sampler`). The defaults bring
        the split R-hat of the per-guide ``mu(0)`` to about 1.1 on 50 000 terminal-only frames
        (1.2-1.3 at 1500 steps), for about 10 s more.
    emcee : bool
        Also sample the tied posterior with emcee (widths, correlations, ESS) as a cross-check.
    check_advice : bool
        With intermediate truth present, measure the band after adding each candidate joint's label.
    seed : int
    """

    model: str = "auto"
    noise_n: float | None = None
    band_frames: int = 1000
    n_chains: int = 64
    n_steps: int = 4000
    thin: int = 60
    emcee: bool = True
    check_advice: bool = True
    seed: int = 0

    def __post_init__(self):
        if self.model not in MODELS:
            raise ConfigError(f"model must be one of {MODELS} (smooth affine-cosine laws), got {self.model!r}")
        if self.noise_n is not None and not self.noise_n > 0:
            raise ConfigError(f"noise_n must be a positive load-cell noise in N, got {self.noise_n!r}")
        for name in ("band_frames", "n_chains", "n_steps", "thin"):
            if int(getattr(self, name)) < 1:
                raise ConfigError(f"{name} must be a positive integer, got {getattr(self, name)!r}")
        if self.n_steps < 2 * self.thin:
            raise ConfigError("n_steps must be at least twice thin")


@dataclass
class TyingStudy:
    """Everything about one tying (``tied`` or ``per-guide``), per tendon where it applies."""

    tying: str
    problem: LawProblem = field(repr=False)
    theta: list[NDArray]
    sigma: list[float]
    spectra: list[Spectrum]
    profiles: list[list[Profile]]
    draws: list[NDArray] = field(repr=False)
    rhat: list[float] = field(default_factory=list)
    band: Band | None = field(default=None, repr=False)

    @property
    def n_params(self) -> int:
        return 3 * self.problem.n_params

    @property
    def rank(self) -> int:
        return sum(s.rank for s in self.spectra)

    @property
    def unidentifiable(self) -> list[str]:
        return [w for s in self.spectra for w in s.words]

    def mu0_sd(self) -> NDArray:
        """Linearised sd of each group's ``mu(0)``, worst over tendons, shape (G,)."""
        g = self.problem.n_groups
        out = np.zeros(g)
        for s in self.spectra:
            for k in range(g):
                v = np.zeros(2 * g)
                v[k] = v[g + k] = 1.0
                out[k] = max(out[k], s.combination_sd(v))
        return out

    def posterior_summary(self) -> dict:
        """Posterior mean, sd and 95 % interval of every parameter and ``mu(0)`` from the draws."""
        out = {}
        g = self.problem.n_groups
        for i, d in enumerate(self.draws):
            names = self.problem.names(i)
            mu0 = d[:, :g] + d[:, g:]
            cols = np.concatenate([d, mu0], axis=1)
            labels = names + [n.replace("A", "mu0", 1) for n in names[:g]]
            q = np.percentile(cols, [2.5, 97.5], axis=0)
            for k, n in enumerate(labels):
                out[n] = {"mean": float(cols[:, k].mean()), "sd": float(cols[:, k].std(ddof=1)),
                          "q2.5": float(q[0, k]), "q97.5": float(q[1, k])}
        return out

    def correlation(self, tendon: int) -> NDArray:
        """Posterior correlation matrix of one tendon's law (from the draws)."""
        d = self.draws[tendon]
        sd = d.std(axis=0)
        c = np.corrcoef(d.T) if np.all(sd > 0) else np.full((d.shape[1],) * 2, np.nan)
        return np.atleast_2d(c)

    def to_dict(self) -> dict:
        conds = [s.condition_number for s in self.spectra]
        full = all(np.isfinite(conds))
        return {
            "n_params": self.n_params,
            "rank": self.rank,
            "n_unidentifiable": self.n_params - self.rank,
            "condition_number": float(max(conds)) if full else None,
            "condition_number_identifiable": float(max(s.identifiable_condition_number for s in self.spectra)),
            "unidentifiable": self.unidentifiable,
            "well_determined": [w for s in self.spectra for w in s.determined],
            "residual_sigma_n": [float(s) for s in self.sigma],
            "per_tendon": [
                {"tendon": i + 1, "rank": s.rank, "n_params": s.n_params,
                 "fisher_eigenvalues": [float(e) for e in s.eigenvalues],
                 "linearised_sd": {n: (float(v) if np.isfinite(v) else None) for n, v in zip(s.names, s.sd)},
                 "profiles": {p.name: p.to_dict() for p in self.profiles[i]}}
                for i, s in enumerate(self.spectra)
            ],
            "profile_verdicts": _count([p.verdict for ps in self.profiles for p in ps]),
            "posterior": self.posterior_summary(),
            "sampler_rhat_max": [float(r) for r in self.rhat],
        }


def _count(items: list[str]) -> dict[str, int]:
    out: dict[str, int] = {}
    for x in items:
        out[x] = out.get(x, 0) + 1
    return out


@dataclass
class IdentifiabilityResult:
    """The single result of :func:`analyse`; :meth:`to_json` gives the DESIGN §10 shape (a floor).

    ``truth`` holds the data's intermediate joint-side truth (T, N, 3) where present; it
    scores the bands and the advice and is never used to fit.
    """

    settings: StudySettings
    source: str
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

    @property
    def misspecification(self) -> dict:
        """Residual noise against the load cells' nominal noise, per tendon (the best tying's)."""
        best = np.minimum(self.studies["tied"].sigma, self.studies["per-guide"].sigma)
        ratio = [float(s / self.noise_n) for s in best]
        return {"residual_sigma_n": [float(s) for s in best], "nominal_noise_n": self.noise_n, "ratio": ratio,
                "misspecified": bool(max(ratio) > MISSPECIFIED_RATIO)}

    def to_json(self) -> dict:
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
            "source": self.source,
            "protocol": self.protocol,
            "frames": self.n_frames,
            "model": self.model_name,
            "tied": tied.to_dict(),
            "per_guide": per.to_dict(),
            "bands": bands,
            "misspecification": self.misspecification,
            "excitation": self.excitation,
            "advice": {
                "instrument_joint": self.instrument_joint,
                "excite_joints": self.excite,
                "candidates": self.instrument,
                "check": self.advice_check,
            },
            "emcee": self.emcee,
            "learned": self.learned,
            "seconds": self.seconds,
        }


def _study(problem: LawProblem, settings: StudySettings, rng_seed: int) -> TyingStudy:
    thetas, sigmas, spectra, profiles, draws, rhats = [], [], [], [], [], []
    layout = problem.layout
    C, d = layout.constraints()
    g = problem.n_groups
    for i in range(3):
        theta = problem.fit(i)
        sigma = max(problem.residual_sigma(theta, i), 1e-9)
        M, b, c0 = problem.quadratic(i, sigma)
        names = problem.names(i)
        s = spectrum(M, names)
        profs = []
        for k, name in enumerate(names):
            e = np.zeros(len(names))
            e[k] = 1.0
            profs.append(profile(M, b, c0, theta, e, layout, name, sd=float(s.sd[k]), structural=not np.isfinite(s.sd[k])))
        for k in range(g):
            e = np.zeros(len(names))
            e[k] = e[g + k] = 1.0
            sd_e = s.combination_sd(e)
            profs.append(profile(M, b, c0, theta, e, layout, names[k].replace("A", "mu0", 1), sd=sd_e,
                                 structural=not np.isfinite(sd_e)))
        start = dispersed_starts(theta, layout, settings.n_chains, rng_seed + i)
        draws.append(hit_and_run(M, b, C, d, start, n_chains=settings.n_chains, n_steps=settings.n_steps,
                                 thin=settings.thin, seed=rng_seed + i))
        rhats.append(float(np.max(split_rhat(draws[-1][:, :g] + draws[-1][:, g:], settings.n_chains))))
        thetas.append(theta)
        sigmas.append(sigma)
        spectra.append(s)
        profiles.append(profs)
    return TyingStudy(problem.tying, problem, thetas, sigmas, spectra, profiles, draws, rhats)


def _base_model(name: str, views: Sequence[Recording]):
    """The calibrated tied model the study is built on (``auto``: the smooth one that fits best)."""
    from tendon_id import zoo

    names = ("capstan-simple", "capstan-contact") if name == "auto" else (name,)
    fitted = [zoo.make(n).fit(views) for n in names]
    return min(fitted, key=lambda m: m.calibration_["loss"])


def _noise_of(recs: Sequence[Recording], noise_n: float | None) -> float:
    if noise_n is not None:
        return float(noise_n)
    sensors = recs[0].meta.get("sensors") or {}
    return float(sensors.get("noise_n", 1.0))


def analyse(data: Recording | Sequence[Recording], settings: StudySettings | None = None, *, learned: bool = False,
            learned_seeds: int = 3, progress: bool | None = None) -> IdentifiabilityResult:
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
    from tendon_id import zoo

    settings = settings or StudySettings()
    t0 = time.perf_counter()
    recs = as_recordings(data)
    views = [r.fitting_view() for r in recs]  # the analysis never reads intermediate truth
    truth = np.concatenate([r.joint_truth for r in recs]) if all(r.has_truth for r in recs) else None
    noise = _noise_of(recs, settings.noise_n)
    steps = ["structure, profiles and posterior (tied)", "structure, profiles and posterior (per-guide)", "bands",
             "advice"] + (["emcee"] if settings.emcee else []) + (["learned cascade"] if learned else [])
    bar = progress_bar(steps, desc="identifiability", enable=progress)
    it = iter(bar)

    base = _base_model(settings.model, views)
    inputs = TransmissionInputs.from_recordings(views, base.geometry_)
    studies: dict[str, TyingStudy] = {}
    for tying in TYINGS:
        next(it, None)
        studies[tying] = _study(LawProblem.from_model(base, inputs, tying, noise), settings, settings.seed)
    next(it, None)
    frames = band_frames(inputs.n_frames, settings.band_frames, settings.seed)
    for st in studies.values():
        st.band = ambiguity_band(st.problem, st.draws, frames, seed=settings.seed)
    coverage = None
    if truth is not None:
        coverage = {t: st.band.coverage(truth) for t, st in studies.items()}

    next(it, None)
    per = studies["per-guide"]
    gate = per.problem.guide_design[..., 1] / np.maximum(inputs.wrap, 1e-12)
    cover = excitation(inputs.wrap, gate if base.block_objects else None)
    scores = instrument_scores(per.problem, per.theta, per.sigma, frames)
    best = max(scores, key=lambda s: s["log_det"])["joint"]
    excite = excite_joints(per.mu0_sd())
    check = None
    if truth is not None and settings.check_advice:
        check = measure_advice(per, truth, frames, settings)

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
        settings=settings, source=str(recs[0].source or "recording"), model_name=base.name, protocol=recs[0].protocol,
        n_frames=inputs.n_frames, n_modules=inputs.n_modules, noise_n=noise, studies=studies, excitation=cover,
        instrument=scores, instrument_joint=int(best), excite=excite, coverage=coverage, advice_check=check,
        emcee=emcee_summary, learned=learned_summary, seconds=time.perf_counter() - t0, truth=truth)


def measure_advice(study: TyingStudy, truth: NDArray, frames: NDArray, settings: StudySettings) -> list[dict]:
    """Measured band after adding each intermediate joint's label (truth plus load-cell noise).

    For each candidate joint ``j`` the per-guide law is sampled again with the extra
    labels ``ln T[1, j] - ln(T_true[j, j] + noise)``, and the mean band width over the
    intermediate joints is measured with the same sampler and frames as the report.
    """
    problem = study.problem
    rng = np.random.default_rng(settings.seed + 1000)
    layout = problem.layout
    C, d = layout.constraints()
    out = []
    for j in range(2, problem.n_guides + 1):
        Xj = problem.joint_design(j)
        draws = []
        for i in range(3):
            t1 = problem.inputs.actuator[:, j - 1, i]
            label = truth[:, j - 1, i] + rng.normal(0.0, problem.noise_n, size=len(t1))
            yj = np.log(t1) - np.log(np.maximum(label, 1e-6))
            wj = 1.0 / (1.0 / t1**2 + 1.0 / label**2)
            sigma = study.sigma[i]
            M, b, _ = problem.quadratic(i, sigma)
            M = M + Xj.T @ (wj[:, None] * Xj) / sigma**2
            b = b + Xj.T @ (wj * yj) / sigma**2
            scale = np.sqrt(np.r_[problem.weight[:, i], wj] / np.mean(problem.weight[:, i]))
            X_all = np.vstack([problem.design, Xj]) * scale[:, None]
            y_all = np.r_[problem.log_drop[:, i], yj] * scale
            theta = _fit_quadratic(X_all, y_all, layout, 1e-10).x
            start = dispersed_starts(theta, layout, settings.n_chains, settings.seed + i)
            draws.append(hit_and_run(M, b, C, d, start, n_chains=settings.n_chains, n_steps=settings.n_steps,
                                     thin=settings.thin, seed=settings.seed + i))
        band = ambiguity_band(problem, draws, frames, seed=settings.seed)
        out.append({"joint": j, "band_width_mean": band.mean_width()})
    return out


def _emcee_tied(base, views, settings: StudySettings) -> dict:
    """Tied posterior with emcee (:mod:`tendon_id.posterior`): widths, A–B correlations, ESS, R-hat."""
    from tendon_id.posterior import sample_posterior

    # Without the encoder marginalisation, so that it targets the same posterior as the hit-and-run draws.
    post = sample_posterior(base, views, target_ess=400.0, max_steps=20000, seed=settings.seed, encoder_bits=None,
                            progress=False)
    A, B = post.law_samples()
    corr = [float(np.corrcoef(A[:, 0, i], B[:, 0, i])[0, 1]) for i in range(3)]
    return {"parameters": post.summary(), "corr_A_B": corr, "mu0_sd": [float(x) for x in (A + B)[:, 0].std(axis=0, ddof=1)],
            "tau": float(np.max(post.tau)), "seconds": post.seconds, "acceptance": post.acceptance}


def learned_comparison(views: Sequence[Recording], truth: NDArray | None, *, seeds: int = 3, preset: str = "fast",
                       progress: bool | None = None) -> dict:
    """Tied against per-guide PG-CHTC: intermediate-joint error against truth and the spread over seeds.

    Both are trained on the same terminal labels (fast preset by default); the spread is the
    sd over seeds of the joint-side estimates, averaged over frames, tendons and the
    intermediate joints [N]: where the terminal data do not pin the split of the friction
    along the robot, differently seeded networks disagree there.
    """
    from tendon_id import zoo
    from tendon_id.metrics import tendon_metrics

    out = {}
    for tied in (True, False):
        preds, rmse = [], []
        for s in range(seeds):
            m = zoo.make("pg-chtc", preset=preset, tied=tied, seed=s, progress=progress).fit(views)
            p = m.predict(views)
            preds.append(p)
            if truth is not None:
                rmse.append(float(np.mean([tendon_metrics(p[:, j], truth[:, j])["rmse"] for j in range(1, p.shape[1] - 1)])))
        preds = np.stack(preds)
        spread = preds.std(axis=0, ddof=1) if seeds > 1 else np.zeros(preds.shape[1:])
        out["tied" if tied else "per_guide"] = {
            "seeds": seeds,
            "preset": preset,
            "joint_rmse": rmse or None,
            "joint_rmse_mean": float(np.mean(rmse)) if rmse else None,
            "seed_spread_mean_n": float(spread[:, 1:-1].mean()),
            "seed_spread_per_joint_n": [float(x) for x in spread.mean(axis=(0, 2))],
        }
    return out
