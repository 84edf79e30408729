"""Settings of the identifiability study (:func:`~tendon_id.identifiability.analyse`), validated on creation."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tendon_id.checks import check_choice
from tendon_id.errors import ConfigError
from tendon_id.identifiability.sampler import dispersed_starts, hit_and_run_many

#: Models the study accepts (``auto`` picks between the two smooth ones).
MODELS = ("auto", "capstan-contact", "capstan-simple")


@dataclass(frozen=True)
class StudySettings:
    """Settings of :func:`~tendon_id.identifiability.analyse` (validated on creation).

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
        With intermediate truth present, check the advice against it: re-fit and re-sample with each
        candidate joint's label, and score the band's width, coverage and RMSE against the truth
        (:func:`~tendon_id.identifiability.advice.measure_advice`); without the check the advice is
        reported as unchecked.
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
            check_choice("model", self.model, MODELS, what="smooth affine-cosine model")
        if self.noise_n is not None and not self.noise_n > 0:
            raise ConfigError(f"noise_n must be a positive load-cell noise in N, got {self.noise_n!r}")
        for name in ("band_frames", "n_chains", "n_steps", "thin"):
            if int(getattr(self, name)) < 1:
                raise ConfigError(f"{name} must be a positive integer, got {getattr(self, name)!r}")
        if self.n_steps < 2 * self.thin:
            raise ConfigError("n_steps must be at least twice thin")

    def sample(self, M, b, C: NDArray, d: NDArray, theta, layout, seed: int) -> list[NDArray]:
        """Draws of several laws of one layout under these sampler settings, from chains dispersed around each.

        Law ``k`` has the Gaussian ``exp(-theta^T M[k] theta / 2 + b[k]^T theta)`` restricted to
        ``C theta <= d`` (see :func:`~tendon_id.identifiability.sampler.hit_and_run_many`);
        ``M`` is (P, q, q), ``b`` and ``theta`` (P, q).  Returns the draws of each, a list of
        P arrays of shape (kept * n_chains, q).
        """
        starts = np.stack([dispersed_starts(th, layout, self.n_chains, seed + k) for k, th in enumerate(theta)])
        kw = {"n_chains": self.n_chains, "n_steps": self.n_steps, "thin": self.thin}
        return list(hit_and_run_many(np.asarray(M), np.asarray(b), C, d, starts, seed=seed, **kw))
