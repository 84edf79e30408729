"""Exact draws from a Gaussian likelihood truncated to a polytope (hit-and-run).

The smooth capstan law has a Gaussian likelihood in its parameters
(:meth:`tendon_id.calibration.problem.LawProblem.quadratic`) and a uniform prior on the feasible
polytope ``C theta <= d`` (``mu >= 0`` on ``[0, pi]`` and the sanity limits of
:class:`~tendon_id.calibration.law_layout.LawLayout`).  Where the data are blind (the Fisher
null space) the posterior is flat and bounded only by that polytope, which is
exactly the set of laws that "fit the terminal data equally well".

Hit-and-run (Smith 1984; Bélisle, Romeijn & Smith 1993): from the current point
pick a random direction, and draw the next point from the exact conditional on
that chord, a one-dimensional truncated normal (uniform where flat).  Directions
are drawn in coordinates whitened by the Fisher information, with a floor so that
flat directions keep a finite scale, which lets one chain move along a tight
``mu(0)`` and a free ``A - B`` alike; during burn-in the map adapts to the chains'
spread (which only changes the proposal of directions, not the exact conditional
draws along them).  Many chains, and several problems of one layout, run at once, vectorised.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr, ndtri

#: Scale given to flat (unidentified) directions when whitening [parameter units].
FLAT_SCALE = 1.0


def _truncated_standard_normal(lo: NDArray, hi: NDArray, rng: np.random.Generator) -> NDArray:
    """Draws of N(0, 1) truncated to ``[lo, hi]`` by the inverse CDF, on the tail nearer zero."""
    u = rng.uniform(size=lo.shape)
    flip = lo > 0  # both bounds in the upper tail: sample the mirror image in the lower one
    a = np.where(flip, -hi, lo)
    b = np.where(flip, -lo, hi)
    pa, pb = ndtr(a), ndtr(b)
    x = ndtri(np.clip(pa + u * (pb - pa), 1e-300, 1 - 1e-16))
    x = np.where(flip, -x, x)
    return np.clip(x, lo, hi)


def hit_and_run(
    M: NDArray,
    b: NDArray,
    C: NDArray,
    d: NDArray,
    start: NDArray,
    *,
    n_chains: int = 64,
    n_steps: int = 600,
    thin: int = 5,
    seed: int = 0,
) -> NDArray[np.float64]:
    """Sample ``p(theta) ∝ exp(-theta^T M theta / 2 + b^T theta)`` on ``C theta <= d``.

    Parameters
    ----------
    M : ndarray, shape (p, p)
        Precision (Fisher information); may be singular.
    b : ndarray, shape (p,)
        Linear term (``X^T W y / sigma^2``).
    C, d : ndarray
        The polytope; it must be bounded.
    start : ndarray, shape (p,) or (n_chains, p)
        Feasible starting point(s), one for all chains or one per chain.
    n_chains, n_steps, thin : int
        Chains run in parallel; the first half of the steps is burn-in, then every
        ``thin``-th state is kept.
    seed : int

    Returns
    -------
    ndarray, shape (n_chains * kept, p)
    """
    start = np.asarray(start, dtype=float)
    return hit_and_run_many(
        np.asarray(M, dtype=float)[None],
        np.asarray(b, dtype=float)[None],
        C,
        d,
        start[None],
        n_chains=n_chains,
        n_steps=n_steps,
        thin=thin,
        seed=seed,
    )[0]


def hit_and_run_many(
    M: NDArray,
    b: NDArray,
    C: NDArray,
    d: NDArray,
    start: NDArray,
    *,
    n_chains: int = 64,
    n_steps: int = 600,
    thin: int = 5,
    seed: int = 0,
) -> NDArray[np.float64]:
    """:func:`hit_and_run` of several problems on one polytope at once (one seeded stream for all).

    A study samples many laws of the same layout (three tendons, and again with each
    candidate joint's labels); stepping them together pays Python's per-step cost once.

    Parameters
    ----------
    M : ndarray, shape (P, p, p)
    b : ndarray, shape (P, p)
    C, d : ndarray
        The polytope shared by the problems.
    start : ndarray, shape (P, p) or (P, n_chains, p)
    n_chains, n_steps, thin, seed :
        As :func:`hit_and_run`.

    Returns
    -------
    ndarray, shape (P, n_chains * kept, p)
    """
    rng = np.random.default_rng(seed)
    n_prob, p = b.shape
    ev, V = np.linalg.eigh(0.5 * (M + np.swapaxes(M, 1, 2)))
    scale = 1.0 / np.sqrt(np.maximum(ev, 0.0) + 1.0 / FLAT_SCALE**2)
    W = V * scale[:, None, :]  # direction maps: whitened -> parameter
    start = np.asarray(start, dtype=float)
    theta = np.broadcast_to(start if start.ndim == 3 else start[:, None, :], (n_prob, n_chains, p)).copy()
    if np.any(theta @ C.T - d > 1e-9):
        raise ValueError("a start point is outside the polytope")
    kept = []
    burn = n_steps // 2
    adapt = {burn // 4, burn // 2, burn}
    for step in range(n_steps):
        if step in adapt and n_chains > p:
            # Adaptive direction map: the chains' spread (flat directions can be far longer than
            # FLAT_SCALE along the polytope), kept full-rank by the whitened map.
            cov = np.stack([np.cov(th.T) for th in theta]) + 1e-6 * (W @ np.swapaxes(W, 1, 2))
            W = np.linalg.cholesky(0.5 * (cov + np.swapaxes(cov, 1, 2)))
        u = rng.standard_normal((n_prob, n_chains, p)) @ np.swapaxes(W, 1, 2)  # (P, chains, p)
        u /= np.linalg.norm(u, axis=2, keepdims=True)
        # Chord: C (theta + t u) <= d.
        cu = u @ C.T
        room = np.maximum(d - theta @ C.T, 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = room / cu
        t_hi = np.min(np.where(cu > 1e-15, ratio, np.inf), axis=2)
        t_lo = np.max(np.where(cu < -1e-15, ratio, -np.inf), axis=2)
        # Conditional along the chord: exp(-a t^2 / 2 + c t).
        Mu = u @ M
        a = np.einsum("ncp,ncp->nc", Mu, u)
        c = np.einsum("ncp,np->nc", u, b) - np.einsum("ncp,ncp->nc", theta, Mu)
        flat = a * (t_hi - t_lo) ** 2 < 1e-8
        sd = 1.0 / np.sqrt(np.where(flat, 1.0, a))
        mean = np.where(flat, 0.0, c / np.where(flat, 1.0, a))
        z = _truncated_standard_normal((t_lo - mean) / sd, (t_hi - mean) / sd, rng)
        t = np.where(flat, t_lo + rng.uniform(size=(n_prob, n_chains)) * (t_hi - t_lo), mean + sd * z)
        t = np.clip(t, t_lo, t_hi)
        theta = theta + t[..., None] * u
        if step >= burn and (step - burn) % thin == 0:
            kept.append(theta.copy())
    return np.concatenate(kept, axis=1)


def split_rhat(draws: NDArray, n_chains: int) -> NDArray[np.float64]:
    """Potential scale reduction per column over the chains of :func:`hit_and_run` (Gelman et al. 2013).

    ``draws`` is the output of :func:`hit_and_run` (kept-major), shape (kept * n_chains, q).
    """
    x = draws.reshape(-1, n_chains, draws.shape[-1])
    n = x.shape[0]
    if n < 2:
        return np.full(draws.shape[-1], np.nan)
    w = x.var(axis=0, ddof=1).mean(axis=0)
    b = n * x.mean(axis=0).var(axis=0, ddof=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.sqrt(((n - 1) / n * w + b / n) / w)
    return np.where(w > 0, r, 1.0)


def dispersed_starts(theta_hat: NDArray, layout, n_chains: int, seed: int, spread: float = 0.3) -> NDArray[np.float64]:
    """Chain starts between the optimum and random feasible laws (convex combinations: feasible).

    The constrained optimum often sits on a vertex of the polytope (``B = |A|`` for
    several guides), where hit-and-run chords are short; starting each chain a random
    fraction (up to ``spread``) of the way towards a random interior law frees them, and
    disperses the chains for the R-hat check.
    """
    rng = np.random.default_rng(seed)
    g = layout.n_groups
    mu0 = np.clip(theta_hat[:g] + theta_hat[g:], 1e-3, 1.8)
    around = layout.join(np.zeros(g), mu0)
    out = np.empty((n_chains, len(theta_hat)))
    for c in range(n_chains):
        target = layout.random_feasible(rng, around)
        lam = rng.uniform(1e-3, spread)
        out[c] = (1.0 - lam) * theta_hat + lam * target
    return out
