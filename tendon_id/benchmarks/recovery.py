"""Parameter recovery: does calibration find a known law, and does the posterior cover it?

On data simulated with a feasible law and no unmodelled effect (load-cell noise and
encoder quantisation only; recipe ``snake12-noise-only``), over several seeds:
the calibrated ``mu_i(0) = A_i + B_i`` against the truth, and whether the posterior's
95 % interval covers the true ``mu_i(0)``.
"""

from __future__ import annotations

import time

import numpy as np

from tendon_id.calibration.posterior import sample_posterior
from tendon_id.datasets import load_recipe
from tendon_id.progress import progress_bar
from tendon_id.sim import simulate
from tendon_id.zoo import make


def recovery(
    *,
    recipe: str = "snake12-noise-only",
    preset: str = "fast",
    seeds: int = 20,
    frames: int = 23000,
    model: str = "capstan-simple",
    protocol: str = "terminal-only",
    progress: bool | None = None,
) -> dict:
    """Run the recovery benchmark; rows hold per-seed errors and coverage, plus a summary."""
    t0 = time.perf_counter()
    r = load_recipe(recipe)
    truth = np.array(r.friction.A) + np.array(r.friction.B)
    per_seed = []
    for seed in progress_bar(range(seeds), desc="recovery", enable=progress):
        rec = simulate(r, protocol, frames=frames, seed=seed).recording
        fitted = make(model).fit(rec)
        post = sample_posterior(fitted, rec, seed=seed)
        mu = post.mu0_samples()[:, 0]
        lo, hi = np.percentile(mu, [2.5, 97.5], axis=0)
        per_seed.append(
            {
                "seed": seed,
                "mu0_fit": fitted.mu0_[0].tolist(),
                "rel_error": ((fitted.mu0_[0] - truth) / truth).tolist(),
                "interval": [lo.tolist(), hi.tolist()],
                "covered": ((lo <= truth) & (truth <= hi)).tolist(),
                "ess_min": float(post.ess.min()),
                "rhat_max": float(post.rhat.max()),
                "posterior_seconds": post.seconds,
            }
        )
    err = np.abs(np.array([s["rel_error"] for s in per_seed]))
    covered = np.array([s["covered"] for s in per_seed])
    summary = {
        "truth_mu0": truth.tolist(),
        "max_rel_error": float(err.max()),
        "within_2_percent": bool(np.all(err <= 0.02)),
        "covered_per_tendon": covered.sum(axis=0).tolist(),
        "covered_all_tendons": int(covered.all(axis=1).sum()),
        "seeds": seeds,
    }
    rows = [
        {"method": model, "protocol": protocol, "terminal": None, "joints": None, "seed": s["seed"], **s}
        for s in per_seed
    ]
    return {
        "benchmark": "recovery",
        "preset": preset,
        "recipe": recipe,
        "rows": rows,
        "summary": summary,
        "seconds": time.perf_counter() - t0,
    }


def format_recovery(result: dict) -> str:
    s = result["summary"]
    lines = [
        f"recovery ({result['recipe']}, {s['seeds']} seeds, {result['seconds']:.1f} s); "
        f"true mu_i(0) = {np.round(s['truth_mu0'], 4).tolist()}"
    ]
    for row in result["rows"]:
        lines.append(
            f"seed {row['seed']:3d}  "
            f"rel. error of mu_i(0) [%] {np.round(np.array(row['rel_error']) * 100, 3).tolist()}  "
            f"95% covered {row['covered']}  ESS min {row['ess_min']:.0f}  R-hat max {row['rhat_max']:.3f}"
        )
    lines.append(
        f"max |rel. error| {s['max_rel_error'] * 100:.3f} % (goal <= 2 %): "
        f"{'ok' if s['within_2_percent'] else 'NOT MET'}"
    )
    lines.append(
        f"95% interval covers the truth: {s['covered_per_tendon']} of {s['seeds']} seeds per tendon, "
        f"all three in {s['covered_all_tendons']} (goal >= 18)"
    )
    return "\n".join(lines)
