"""One tying's identifiability study: fit, Fisher spectrum, profiles and exact posterior draws.

See :doc:`/guide/identifiability`.

:func:`study_tying` runs it on an :class:`~tendon_id.identifiability.problem.IdentifiabilityProblem`
and returns a :class:`TyingStudy`, whose :meth:`~TyingStudy.to_dict` is the ``tied`` /
``per_guide`` part of the study's JSON.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from tendon_id.identifiability.band import Band
from tendon_id.identifiability.problem import IdentifiabilityProblem
from tendon_id.identifiability.profile import Profile, profile
from tendon_id.identifiability.sampler import split_rhat
from tendon_id.identifiability.settings import StudySettings
from tendon_id.identifiability.spectrum import WELL_DETERMINED_SD, Spectrum, spectrum


@dataclass
class TyingStudy:
    """Everything about one tying (``tied`` or ``per-guide``), per tendon where it applies."""

    tying: str
    problem: IdentifiabilityProblem = field(repr=False)
    theta: list[NDArray]
    sigma: list[float]
    spectra: list[Spectrum]
    profiles: list[list[Profile]]
    draws: list[NDArray] = field(repr=False)
    rhat: list[float] = field(default_factory=list)
    band: Band | None = field(default=None, repr=False)

    @property
    def n_params(self) -> int:
        return self.problem.n_tendons * self.problem.n_params

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
                out[n] = {
                    "mean": float(cols[:, k].mean()),
                    "sd": float(cols[:, k].std(ddof=1)),
                    "q2.5": float(q[0, k]),
                    "q97.5": float(q[1, k]),
                }
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
            # Only directions whose unit-norm sd is at most WELL_DETERMINED_SD; the rest of the
            # identifiable directions are "sloppy" (identifiable, but too loose to quote).
            "well_determined": [w for s in self.spectra for w in s.determined],
            "sloppy": [w for s in self.spectra for w in s.sloppy],
            "n_well_determined": sum(s.n_determined for s in self.spectra),
            "n_sloppy": sum(s.n_sloppy for s in self.spectra),
            "well_determined_sd_max": WELL_DETERMINED_SD,
            "residual_sigma_n": [float(s) for s in self.sigma],
            "per_tendon": [
                {
                    "tendon": i + 1,
                    "rank": s.rank,
                    "n_params": s.n_params,
                    "fisher_eigenvalues": [float(e) for e in s.eigenvalues],
                    "linearised_sd": {n: (float(v) if np.isfinite(v) else None) for n, v in zip(s.names, s.sd)},
                    "profiles": {p.name: p.to_dict() for p in self.profiles[i]},
                }
                for i, s in enumerate(self.spectra)
            ],
            "profile_verdicts": _count([p.verdict for ps in self.profiles for p in ps]),
            "posterior": self.posterior_summary(),
            "sampler_rhat_max": [float(r) for r in self.rhat],
        }


def _count(items: list[str]) -> dict[str, int]:
    """How often each item occurs, in first-seen order."""
    out: dict[str, int] = {}
    for x in items:
        out[x] = out.get(x, 0) + 1
    return out


def study_tying(problem: IdentifiabilityProblem, settings: StudySettings, rng_seed: int) -> TyingStudy:
    """Fit, spectrum, profiles and exact posterior draws of every tendon's law under one tying.

    Per tendon: the weighted constrained fit, the residual noise, the Fisher spectrum of
    the quadratic likelihood, profile likelihoods of every parameter and every group's
    ``mu(0) = A + B``, and hit-and-run draws from dispersed starts with their split R-hat.
    """
    thetas, sigmas, spectra, profiles, quads = [], [], [], [], []
    layout = problem.layout
    C, d = layout.constraints()
    g = problem.n_groups
    for i in range(problem.n_tendons):
        theta = problem.fit(i)
        sigma = max(problem.residual_sigma(theta, i), 1e-9)
        M, b, c0 = problem.quadratic(i, sigma)
        names = problem.names(i)
        s = spectrum(M, names)
        profs = []
        for k, name in enumerate(names):
            e = np.zeros(len(names))
            e[k] = 1.0
            profs.append(
                profile(M, b, c0, theta, e, layout, name, sd=float(s.sd[k]), structural=not np.isfinite(s.sd[k]))
            )
        for k in range(g):
            e = np.zeros(len(names))
            e[k] = e[g + k] = 1.0
            sd_e = s.combination_sd(e)
            profs.append(
                profile(
                    M,
                    b,
                    c0,
                    theta,
                    e,
                    layout,
                    names[k].replace("A", "mu0", 1),
                    sd=sd_e,
                    structural=not np.isfinite(sd_e),
                )
            )
        quads.append((M, b))
        thetas.append(theta)
        sigmas.append(sigma)
        spectra.append(s)
        profiles.append(profs)
    # The three tendons' laws are sampled together (one stream, seeded by rng_seed).
    draws = settings.sample([q[0] for q in quads], [q[1] for q in quads], C, d, thetas, layout, rng_seed)
    rhats = [float(np.max(split_rhat(dr[:, :g] + dr[:, g:], settings.n_chains))) for dr in draws]
    return TyingStudy(problem.tying, problem, thetas, sigmas, spectra, profiles, draws, rhats)


def check_learned_inputs(recs, preset: str = "fast") -> None:
    """Raise :class:`~tendon_id.errors.ConfigError` now if the learned comparison could not train on ``recs``.

    The comparison trains PG-CHTC last, after minutes of analysis; what its fit would refuse (one
    trajectory, trajectories shorter than the history window) is checked before the analysis starts.

    Parameters
    ----------
    recs : sequence of Recording
    preset : str
        The PG-CHTC preset of the comparison.
    """
    from learners.presets import preset as get_preset
    from tendon_id.errors import ConfigError

    if sum(len(r.trajectories) for r in recs) < 2:
        raise ConfigError("PG-CHTC needs at least two trajectories (one to train on, one to validate)", param="learned")
    window = get_preset(preset).unit.window
    for r in recs:
        r.check_history_window(window)
