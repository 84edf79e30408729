"""The snake chain's posterior: the capstan law ``(A_i, B_i)`` and the noise (:doc:`/guide/calibration`).

The likelihood the generic sampler (:func:`tendon_id.calibration.posterior.sample_posterior`)
runs for a capstan model of the snake chain.

Likelihood: load-cell noise.  Both the actuator-side input and the terminal
label are read by load cells with noise ``sigma_i`` [N] (one per tendon), so
the terminal log residual ``r_t = ln T_hat[N, N, i] - ln T[N, N, i]`` has
variance ``sigma_i^2 (1 / T[1, N]^2 + 1 / T[N, N]^2)`` to first order (the
delta method): a heteroscedastic Gaussian whose weights
(:func:`~tendon_id.calibration.problem.delta_method_weight`) come from the measured tensions.
Prior: uniform on the feasible set ``B >= |A|`` (``mu >= 0`` on ``[0, pi]``) within
the sanity limits of :class:`~tendon_id.calibration.law_layout.LawLayout`, and uniform in
``ln sigma_i`` [ln N] on :data:`~tendon_id.calibration.posterior.LOG_SIGMA_RANGE`.  Design, weights
and layout are those of the model's :class:`~tendon_id.calibration.problem.LawProblem`, the one calibration fits.

For smooth models (``ln T_N`` linear in the law) the log-probability needs only
``X^T W X``, ``X^T W y`` and ``y^T W y`` (:meth:`~tendon_id.calibration.problem.LawProblem.quadratic`),
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

The walkers, the moves and the convergence are the generic sampler's.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration.encoder import encoder_covariance
from tendon_id.calibration.law_layout import LawLayout
from tendon_id.calibration.posterior import LOG_SIGMA_RANGE, Factor, Likelihood, Posterior
from tendon_id.calibration.problem import LawProblem
from tendon_id.data import Recording

__all__ = ["PosteriorResult", "law_likelihood", "parameter_names", "to_theta"]


def parameter_names(model) -> list[str]:
    """Names of the sampled parameters: ``A_i``, ``B_i`` (``A_k<g>_i`` per guide), then ``log_sigma_i``."""
    g, m = model.A_.shape  # guide groups, tendons per set
    law = ("A", "B") if model.mu_law == "affine-cosine" else ("mu",)
    names = []
    for i in range(1, m + 1):
        for p in law:
            names += [f"{p}_{i}"] if g == 1 else [f"{p}_k{k + 1}_{i}" for k in range(g)]
    return names + [f"log_sigma_{i}" for i in range(1, m + 1)]


@dataclass
class PosteriorResult(Posterior):
    """The snake chain's posterior (the fields of :class:`~tendon_id.calibration.posterior.Posterior`).

    ``names`` are those of :func:`parameter_names`; ``log_sigma_i`` is the natural log of tendon
    ``i``'s load-cell noise in N. ``tau`` is per sampled coordinate ``(mu0, r)`` per group, then
    ``log_sigma``.

    Attributes
    ----------
    layout : LawLayout
        The law's parameter layout.
    encoder_cov : ndarray or None
        Law covariance from encoder quantisation, shape (n, p, p), convolved into ``chain``.
    """

    layout: LawLayout = field(repr=False, default=None)
    encoder_cov: NDArray | None = field(repr=False, default=None)

    def law_samples(self) -> tuple[NDArray, NDArray]:
        """Draws of ``A`` and ``B``, each shape (draws, G, n) for n tendons per set."""
        s = self.samples
        p = self.layout.size
        m = s.shape[1] // (p + 1)  # each tendon's law and its noise
        A = np.empty((s.shape[0], self.layout.n_groups, m))
        B = np.empty_like(A)
        for i in range(m):
            a, b = self.layout.split(s[:, i * p : (i + 1) * p].T)
            A[:, :, i], B[:, :, i] = a.T, b.T
        return A, B

    def mu0_samples(self) -> NDArray:
        """Draws of ``mu_i(0) = A_i + B_i``, shape (draws, G, n)."""
        A, B = self.law_samples()
        return A + B

    def predictive_bands(
        self,
        model,
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
            ``"lo"``, ``"median"``, ``"hi"``: arrays of shape (T, N, n) (parameter
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

    ``A = r mu0 / 2`` and ``B = mu0 - A`` for the affine-cosine law
    (:class:`~tendon_id.calibration.law_layout.LawLayout`);
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

    The walkers move in the free box coordinates ``(mu0, r)`` of :class:`~tendon_id.calibration.law_layout.LawLayout`,
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


def law_likelihood(
    model, data: Recording | Sequence[Recording], *, encoder_bits: int | str | None = "auto"
) -> Likelihood:
    """The posterior of a calibrated capstan model's law and noise, one factor per tendon (see the module docstring).

    Parameters
    ----------
    model : CapstanModel
        A fitted model; its calibrated law starts the walkers.
    data : Recording or sequence
        The calibration data (terminal labels only are used).
    encoder_bits : int, "auto" or None
        Resolution of the joint encoders, whose quantisation error is marginalised (see the
        module docstring). ``"auto"``: the recordings' ``sensors.encoder_bits`` metadata, else
        12 (the paper's robot); None ignores it.
    """
    recs = [r.fitting_view() for r in model.family.recordings(data)]
    inputs = model.inputs(recs)  # raises NotFittedError on an unfitted model
    if encoder_bits == "auto":
        encoder_bits = int((recs[0].meta.get("sensors") or {}).get("encoder_bits", 12))
    # The fitted block parameters; every frame counts here, the warm-up included.
    problem = LawProblem.from_model(model, inputs, values=model.block_params_)
    layout = problem.layout
    n_obs = inputs.n_frames
    m = inputs.n_tendons
    theta_law = np.stack([layout.join(model.A_[:, i], model.B_[:, i]) for i in range(m)])  # (n, p)
    # The likelihood and the prior factorise over the tendons (each has its own law and noise), so
    # each tendon is sampled on its own: n samplers of p + 1 dimensions mix in far fewer steps
    # than one of n (p + 1).
    tendon_lp = [_TendonLogProb(problem, model.is_smooth, i) for i in range(m)]
    resid = np.array([lp.sse(theta_law[i][None])[0] for i, lp in enumerate(tendon_lp)])
    sigma0 = np.sqrt(np.maximum(resid / n_obs, 1e-20))
    zlb, zub = layout.free_bounds()
    factors = [
        Factor(
            log_prob=lp,
            centre=np.r_[layout.to_free(theta_law[i]), np.log(sigma0[i])],
            lower=np.r_[zlb, LOG_SIGMA_RANGE[0]],
            upper=np.r_[zub, LOG_SIGMA_RANGE[1]],
            vectorize=True,
            desc=f"emcee, tendon {i + 1} of {m}",
        )
        for i, lp in enumerate(tendon_lp)
    ]

    def finish(z_chain: NDArray, rng: np.random.Generator, seed: int) -> tuple[NDArray, dict]:
        """The sampled ``(mu0, r)`` to ``(A, B)``, and the encoder's spread convolved in."""
        chain = to_theta(z_chain.reshape(-1, z_chain.shape[-1]), layout).reshape(z_chain.shape)
        encoder_cov = None
        if encoder_bits:
            encoder_cov = encoder_covariance(model, inputs, 2.0 * np.pi / 2**encoder_bits, seed=seed)
            convolve_encoder(chain, encoder_cov, layout, rng)
        return chain, {"encoder_cov": encoder_cov}

    return Likelihood(
        factors=factors,
        names=parameter_names(model),
        map_theta=np.r_[theta_law.ravel(), np.log(sigma0)],
        n_walkers=32,
        target_ess=1000.0,
        max_steps=50000,
        chunk=500,
        finish=finish,
        result=PosteriorResult,
        extra={"layout": layout},
    )


def convolve_encoder(chain: NDArray, cov: NDArray, layout: LawLayout, rng: np.random.Generator) -> None:
    """Add draws of the encoder's law covariance ``cov`` (n, p, p) to ``chain``'s laws, in place, keeping them feasible.

    A shifted draw that leaves the feasible set is drawn again (up to 20 times), then kept unshifted.
    """
    p = layout.size
    for i in range(cov.shape[0]):
        law = chain[:, :, i * p : (i + 1) * p]
        shift = rng.multivariate_normal(np.zeros(p), cov[i], size=law.shape[:2], check_valid="ignore")
        moved = law + shift
        for _ in range(20):  # keep draws in the feasible set: redraw the shifts that leave it
            bad = ~layout.feasible(moved)
            if not bad.any():
                break
            moved[bad] = law[bad] + rng.multivariate_normal(
                np.zeros(p), cov[i], size=int(bad.sum()), check_valid="ignore"
            )
        bad = ~layout.feasible(moved)
        moved[bad] = law[bad]
        chain[:, :, i * p : (i + 1) * p] = moved
