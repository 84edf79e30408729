"""Bayesian posterior of the capstan law ``(A_i, B_i)`` and the noise, with emcee (DESIGN §7).

Likelihood: load-cell noise.  Both the actuator-side input and the terminal
label are read by load cells with noise ``sigma_i`` [N] (one per tendon), so
the terminal log residual ``r_t = ln T_hat[N, N, i] - ln T[N, N, i]`` has
variance ``sigma_i^2 (1 / T[1, N]^2 + 1 / T[N, N]^2)`` to first order (the
delta method): a heteroscedastic Gaussian whose weights
(:func:`~tendon_id.problem.delta_method_weight`) come from the measured tensions.
Prior: uniform on the feasible set ``B >= |A|`` (``mu >= 0`` on ``[0, pi]``) within
the sanity limits of :class:`~tendon_id.law_layout.LawLayout`, and uniform in
``ln sigma_i`` [ln N] on ``[-12, 6]``.  Design, weights and layout are those of the
model's :class:`~tendon_id.problem.LawProblem`, the one calibration fits.

For smooth models (``ln T_N`` linear in the law) the log-probability needs only
``X^T W X``, ``X^T W y`` and ``y^T W y`` (:meth:`~tendon_id.problem.LawProblem.quadratic`),
so it costs O(1) per walker whatever the number of frames; it is vectorised over
walkers (``emcee``'s ``vectorize=True``).
Nonsmooth models evaluate the chain per walker and are much slower.
Likelihood and prior factorise over the three tendons, so each tendon's law and noise are
sampled by a sampler of their own; the draws of the three are then set side by side.

Encoder resolution: the model reads quantised joint angles, and while a joint is
held its quantisation error stays the same for many frames, so it does not
average out like load-cell noise.  The posterior marginalises it: the law is
refitted (smooth surrogate, exact constrained least squares) on angles shifted
by independent uniform offsets of plus or minus half an encoder step, one per
run of identical readings, and the spread of those refits is convolved into the
sampled chain (a linearised errors-in-variables marginalisation).

Convergence follows the integrated autocorrelation time (Goodman & Weare 2010;
emcee's ``get_autocorr_time``): sampling continues until the chain is longer
than 50 ``tau`` and the effective sample size of every parameter reaches the
target.  ESS and R-hat of the result come from ArviZ (:mod:`tendon_id.mcmc`).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import emcee
import numpy as np
from numpy.typing import NDArray

from tendon_id.data import Recording
from tendon_id.encoder import encoder_covariance
from tendon_id.errors import ConfigError
from tendon_id.law_layout import LawLayout
from tendon_id.mcmc import Chains, corner_figure, ess_rhat, run_to_convergence
from tendon_id.problem import LawProblem
from tendon_id.zoo.capstan import CapstanModel
from tendon_id.zoo.inputs import as_recordings

LOG_SIGMA_RANGE = (-12.0, 6.0)


def de_moves() -> list:
    """emcee's differential-evolution moves, a fresh set for one sampler.

    DE-MC (ter Braak 2006, Statistics and Computing 16) with 20 % snooker updates (ter Braak &
    Vrugt 2008, Statistics and Computing 18).  On the law's posterior their autocorrelation time
    is about 2.5 times shorter than the default stretch move's (measured on the snake12-paper pool).
    """
    return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]


def parameter_names(model: CapstanModel) -> list[str]:
    """Names of the sampled parameters: ``A_i``, ``B_i`` (``A_k<g>_i`` per guide), then ``log_sigma_i``."""
    g = model.A_.shape[0]
    law = ("A", "B") if model.mu_law == "affine-cosine" else ("mu",)
    names = []
    for i in range(1, 4):
        for p in law:
            names += [f"{p}_{i}"] if g == 1 else [f"{p}_k{k + 1}_{i}" for k in range(g)]
    return names + [f"log_sigma_{i}" for i in range(1, 4)]


@dataclass
class PosteriorResult(Chains):
    """Samples and diagnostics of :func:`sample_posterior` (the fields of :class:`~tendon_id.mcmc.Chains`).

    ``names`` are those of :func:`parameter_names`; ``log_sigma_i`` is the natural log of tendon
    ``i``'s load-cell noise in N. ``tau`` is per sampled coordinate ``(mu0, r)`` per group, then
    ``log_sigma``.

    Attributes
    ----------
    layout : LawLayout
        The law's parameter layout.
    encoder_cov : ndarray or None
        Law covariance from encoder quantisation, shape (3, p, p), convolved into ``chain``.
    """

    layout: LawLayout = field(repr=False, default=None)
    encoder_cov: NDArray | None = field(repr=False, default=None)

    def law_samples(self) -> tuple[NDArray, NDArray]:
        """Draws of ``A`` and ``B``, each shape (draws, G, 3)."""
        s = self.samples
        p = self.layout.size
        A = np.empty((s.shape[0], self.layout.n_groups, 3))
        B = np.empty_like(A)
        for i in range(3):
            a, b = self.layout.split(s[:, i * p : (i + 1) * p].T)
            A[:, :, i], B[:, :, i] = a.T, b.T
        return A, B

    def mu0_samples(self) -> NDArray:
        """Draws of ``mu_i(0) = A_i + B_i``, shape (draws, G, 3)."""
        A, B = self.law_samples()
        return A + B

    def corner(self, truths: Sequence[float] | None = None):
        """Corner plot of the law parameters (``corner`` package); returns the figure."""
        keep = [k for k, n in enumerate(self.names) if not n.startswith("log_sigma")]
        return corner_figure(
            self.samples[:, keep],
            [self.names[k] for k in keep],
            None if truths is None else [truths[k] for k in keep],
        )

    def predictive_bands(
        self,
        model: CapstanModel,
        data: Recording | Sequence[Recording],
        *,
        n_draws: int = 100,
        quantiles: tuple[float, float] = (2.5, 97.5),
        seed: int = 0,
    ) -> dict[str, NDArray]:
        """Posterior-predictive bands of the joint-side tensions ``T[j, j, i]`` [N].

        Returns
        -------
        dict
            ``"lo"``, ``"median"``, ``"hi"``: arrays of shape (T, N, 3) (parameter
            uncertainty only; measurement noise is not added).
        """
        inputs = model.inputs(data)
        A, B = self.law_samples()
        rng = np.random.default_rng(seed)
        pick = rng.choice(A.shape[0], size=min(n_draws, A.shape[0]), replace=False)
        values = model.block_params_
        draws = np.stack(
            [np.exp(model.propagate(inputs, A[d], B[d], values, keep_chain=False)).astype(np.float32) for d in pick]
        )
        lo, med, hi = np.percentile(draws, [quantiles[0], 50.0, quantiles[1]], axis=0)
        return {"lo": lo, "median": med, "hi": hi}


def to_theta(z: NDArray, layout: LawLayout) -> NDArray:
    """Sampled coordinates ``(mu0, r)`` per group, then ``ln sigma``, to ``(A, B)``, then ``ln sigma``, rows (W, .).

    ``A = r mu0 / 2`` and ``B = mu0 - A`` for the affine-cosine law (:class:`~tendon_id.law_layout.LawLayout`);
    a constant law is sampled as it is.  Laws of any number of tendons lie side by side before the noises.
    """
    theta = np.array(z, dtype=float, copy=True)
    if layout.mu_law != "affine-cosine":
        return theta
    p, g = layout.size, layout.n_groups
    for i in range(int(np.shape(z)[1]) // (p + 1)):
        blk = z[:, i * p : (i + 1) * p]
        A = 0.5 * blk[:, g:] * blk[:, :g]
        theta[:, i * p : i * p + g] = A
        theta[:, i * p + g : (i + 1) * p] = blk[:, :g] - A
    return theta


class _TendonLogProb:
    """Log-posterior of one tendon's law and noise, ``z = (law in (mu0, r) coordinates, ln sigma)``, rows (W, p + 1).

    The walkers move in the free box coordinates ``(mu0, r)`` of :class:`~tendon_id.law_layout.LawLayout`,
    where the feasible set is a box and ``mu0``, the combination the data pins down, is an axis;
    the prior stays uniform in ``(A, B)`` through the Jacobian ``|d(A, B)/d(mu0, r)| = mu0 / 2``.
    A non-finite likelihood (a law whose prediction overflows) is ``-inf``: that walker's move
    is rejected instead of stopping the sampler.
    """

    def __init__(self, problem: LawProblem, smooth: bool, tendon: int):
        self.problem, self.tendon = problem, tendon
        self.layout = problem.layout
        self.n_obs = problem.inputs.n_frames
        self.lb, self.ub = self.layout.free_bounds()
        self.quad = problem.quadratic(tendon) if smooth else None  # delta-method weighted (M, b, c) at 1 N
        self.log_label = np.log(problem.inputs.terminal[:, tendon])

    def sse(self, theta: NDArray) -> NDArray:
        """Weighted sum of squared log errors at 1 N noise, per row of laws ``theta`` (W, p) [N^2]."""
        if self.quad is not None:
            M, b, c = self.quad
            return np.einsum("wp,pq,wq->w", theta, M, theta) - 2.0 * theta @ b + c
        out = np.empty(theta.shape[0])
        for w, th in enumerate(theta):
            A, B = self.layout.split(th)
            pred = self.problem.terminal_reading(A[:, None], B[:, None], tendons=np.array([self.tendon]))[:, 0]
            out[w] = np.sum(self.problem.weight[:, self.tendon] * (np.log(pred) - self.log_label) ** 2)
        return out

    def __call__(self, z: NDArray) -> NDArray:
        z = np.atleast_2d(z)
        p, g = self.layout.size, self.layout.n_groups
        lp = np.full(z.shape[0], -np.inf)
        law, log_sigma = z[:, :p], z[:, p]
        ok = np.all((law >= self.lb) & (law <= self.ub), axis=1)
        ok &= (log_sigma >= LOG_SIGMA_RANGE[0]) & (log_sigma <= LOG_SIGMA_RANGE[1])
        affine = self.layout.mu_law == "affine-cosine"
        if affine:
            ok &= np.all(law[:, :g] > 0, axis=1)
        if ok.any():
            theta = to_theta(z[ok], self.layout)[:, :p]
            with np.errstate(over="ignore", invalid="ignore"):
                lp[ok] = -self.n_obs * log_sigma[ok] - 0.5 * self.sse(theta) * np.exp(-2.0 * log_sigma[ok])
            if affine:
                lp[ok] += np.sum(np.log(0.5 * law[ok][:, :g]), axis=1)
        lp[~np.isfinite(lp)] = -np.inf
        return lp


def sample_posterior(
    model: CapstanModel,
    data: Recording | Sequence[Recording],
    *,
    n_walkers: int = 32,
    target_ess: float = 1000.0,
    max_steps: int = 50000,
    chunk: int = 500,
    seed: int = 0,
    encoder_bits: int | str | None = "auto",
    progress: bool | None = None,
) -> PosteriorResult:
    """Sample the posterior of a calibrated capstan model's law and noise.

    Parameters
    ----------
    model : CapstanModel
        A fitted model; its calibrated law starts the walkers.
    data : Recording or sequence
        The calibration data (terminal labels only are used).
    n_walkers : int
        emcee walkers of each tendon's sampler (at least twice its ``p + 1`` parameters).
    target_ess : float
        Effective sample size to reach for every parameter.
    max_steps : int
        Give up after this many steps (the result then says so through its ESS).
    chunk : int
        Steps between convergence checks.
    seed : int
        Seeds the walkers' start and the sampler.
    encoder_bits : int, "auto" or None
        Resolution of the joint encoders, whose quantisation error is
        marginalised (see the module docstring). ``"auto"``: the recordings'
        ``sensors.encoder_bits`` metadata, else 12 (the paper's robot); None
        ignores it.
    progress : bool, optional
        Progress bar (default: on a terminal).
    """
    if not isinstance(model, CapstanModel):
        raise ConfigError("the posterior is defined for the capstan family of models")
    recs = [r.fitting_view() for r in as_recordings(data)]
    inputs = model.inputs(recs)  # raises NotFittedError on an unfitted model
    if encoder_bits == "auto":
        encoder_bits = int((recs[0].meta.get("sensors") or {}).get("encoder_bits", 12))
    # The fitted block parameters; every frame counts here, the warm-up included.
    problem = LawProblem.from_model(model, inputs, values=model.block_params_)
    layout = problem.layout
    p = layout.size
    names = parameter_names(model)
    ndim = len(names)
    if n_walkers < 2 * (p + 1):  # each tendon's sampler has p + 1 dimensions
        n_walkers = 2 * (p + 1)
    n_obs = inputs.n_frames
    theta_law = np.stack([layout.join(model.A_[:, i], model.B_[:, i]) for i in range(3)])  # (3, p)

    # The likelihood and the prior factorise over the tendons (each has its own law and noise), so
    # each tendon is sampled on its own: three samplers of p + 1 dimensions mix in far fewer steps
    # than one of 3 (p + 1) (the stretch move's autocorrelation grows with the dimension).
    tendon_lp = [_TendonLogProb(problem, model.is_smooth, i) for i in range(3)]

    # Start: the calibrated law and the residual noise, in a small ball inside the box.
    rng = np.random.default_rng(seed)
    resid = np.array([lp.sse(theta_law[i][None])[0] for i, lp in enumerate(tendon_lp)])
    sigma0 = np.sqrt(np.maximum(resid / n_obs, 1e-20))
    z_law = np.concatenate([layout.to_free(theta_law[i]) for i in range(3)])
    centre = np.r_[z_law, np.log(sigma0)]
    zlb, zub = layout.free_bounds()
    span = np.r_[np.tile(zub - zlb, 3), np.full(3, 1.0)]
    inner_lo = np.r_[np.tile(zlb, 3), np.full(3, LOG_SIGMA_RANGE[0])] + 1e-6 * span
    inner_hi = np.r_[np.tile(zub, 3), np.full(3, LOG_SIGMA_RANGE[1])] - 1e-6 * span
    start = np.clip(centre + 1e-4 * span * rng.standard_normal((n_walkers, ndim)), inner_lo, inner_hi)

    t0 = time.perf_counter()
    parts, taus, acceptance = [], [], []
    for i, lp in enumerate(tendon_lp):
        cols = np.r_[np.arange(i * p, (i + 1) * p), 3 * p + i]  # tendon i's law, then its log sigma
        if not np.all(np.isfinite(lp(start[:, cols]))):  # pragma: no cover - the clip keeps every start inside
            raise ConfigError("could not place the walkers in the feasible region")
        sampler = emcee.EnsembleSampler(n_walkers, p + 1, lp, moves=de_moves(), vectorize=True)
        sampler.random_state = np.random.RandomState([seed, i]).get_state()  # the same seed gives the same chain
        z_i, tau_i = run_to_convergence(
            sampler,
            start[:, cols],
            target_ess=target_ess,
            max_steps=max_steps,
            chunk=chunk,
            progress=progress,
            desc=f"emcee, tendon {i + 1} of 3",
        )
        parts.append(z_i)
        taus.append(tau_i)
        acceptance.append(float(np.mean(sampler.acceptance_fraction)))
    steps = min(z.shape[0] for z in parts)  # independent tendons: the last draws of each, side by side
    z_chain = np.concatenate([z[-steps:, :, :p] for z in parts] + [z[-steps:, :, p:] for z in parts], axis=2)
    tau = np.r_[np.concatenate([t[:p] for t in taus]), [t[p] for t in taus]]
    chain = to_theta(z_chain.reshape(-1, ndim), layout).reshape(z_chain.shape)
    encoder_cov = None
    if encoder_bits:
        encoder_cov = encoder_covariance(model, inputs, 2.0 * np.pi / 2**encoder_bits, seed=seed)
        for i in range(3):
            law = chain[:, :, i * p : (i + 1) * p]
            shift = rng.multivariate_normal(np.zeros(p), encoder_cov[i], size=law.shape[:2], check_valid="ignore")
            moved = law + shift
            for _ in range(20):  # keep draws in the feasible set: redraw the shifts that leave it
                bad = ~layout.feasible(moved)
                if not bad.any():
                    break
                moved[bad] = law[bad] + rng.multivariate_normal(
                    np.zeros(p), encoder_cov[i], size=int(bad.sum()), check_valid="ignore"
                )
            bad = ~layout.feasible(moved)
            moved[bad] = law[bad]
            chain[:, :, i * p : (i + 1) * p] = moved
    ess, rhat = ess_rhat(names, chain)
    return PosteriorResult(
        names=names,
        chain=chain,
        tau=tau,
        ess=ess,
        rhat=rhat,
        acceptance=float(np.mean(acceptance)),
        seconds=time.perf_counter() - t0,
        map_theta=np.r_[theta_law.ravel(), np.log(sigma0)],
        layout=layout,
        encoder_cov=encoder_cov,
    )
