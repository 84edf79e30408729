"""What to measure next: which joint to instrument (D-optimal) and which joints to excite.

Instrumenting joint ``j`` adds the labels ``ln T[1, j] - ln T[j, j] = x_j(t) . theta``
(set ``j`` passes guides ``1..j-1``), so its Fisher information adds
``X_j^T W_j X_j / sigma^2``.  The D-optimal joint maximises
``sum_i log det(F_i + F_j,i + F_0)`` over the tendons ``i``, with ``F_0 = I / s^2`` the
weak prior that keeps the determinant finite in the null space (``s`` =
:data:`~tendon_id.identifiability.sampler.FLAT_SCALE`; Atkinson, Donev & Tobias 2007,
"Optimum experimental designs", ch. 10).  The expected shrinkage of the band is
the linearised one: the mean over frames and intermediate joints of
``sqrt(x_l^T (F + F_0)^-1 x_l)`` before and after.  Where intermediate truth exists,
:func:`measure_advice` checks the advice against it by adding each joint's (noisy) label and
sampling again, and :func:`judge_advice` says whether the check confirms the linearised advice
(rule: :data:`CONFIRM_RULE`); without truth the advice stays unchecked.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration.problem import constrained_lstsq, delta_method_weight
from tendon_id.identifiability.band import ambiguity_band
from tendon_id.identifiability.problem import IdentifiabilityProblem
from tendon_id.identifiability.sampler import FLAT_SCALE
from tendon_id.identifiability.settings import StudySettings
from tendon_id.identifiability.study import TyingStudy


def _joint_weight(problem: IdentifiabilityProblem, joint: int, tendon: int, theta: NDArray) -> NDArray:
    """Delta-method weights [N^2] of a label at ``joint``, its tension predicted by ``theta``."""
    t1 = problem.inputs.actuator[:, joint - 1, tendon]
    tj = t1 * np.exp(-problem.joint_design(joint) @ theta)
    return delta_method_weight(t1, tj)


def _linear_band_sd(problem: IdentifiabilityProblem, cov: NDArray, frames: NDArray) -> float:
    """Mean linearised sd of ``ln T[j, j]`` over ``frames`` and joints ``2..N-1``."""
    sds = []
    for j in range(2, problem.n_guides + 1):
        X = problem.joint_design(j)[frames]
        sds.append(np.sqrt(np.maximum(np.einsum("tp,pq,tq->t", X, cov, X), 0.0)).mean())
    return float(np.mean(sds))


def instrument_scores(
    problem: IdentifiabilityProblem, thetas: list[NDArray], sigmas: list[float], frames: NDArray
) -> list[dict]:
    """D-criterion and expected band shrinkage for instrumenting each intermediate joint.

    Parameters
    ----------
    problem : IdentifiabilityProblem
        Usually the per-guide problem (the tied law is already determined).
    thetas, sigmas : per tendon
        Fitted law and residual noise [N].
    frames : ndarray of int
        Frames over which the band is averaged.

    Returns
    -------
    list of dict
        ``joint``, ``log_det`` (summed over tendons) and ``expected_shrinkage`` (fraction of
        the mean linearised band sd removed), one per joint ``2..N-1``.
    """
    p = problem.n_params
    F0 = np.eye(p) / FLAT_SCALE**2
    tendons = range(problem.n_tendons)
    base = [problem.precision(i, sigmas[i]) + F0 for i in tendons]
    before = np.mean([_linear_band_sd(problem, np.linalg.inv(base[i]), frames) for i in tendons])
    out = []
    for j in range(2, problem.n_guides + 1):
        Xj = problem.joint_design(j)
        logdet, after = 0.0, []
        for i in tendons:
            F = base[i] + problem.precision(i, sigmas[i], design=Xj, weight=_joint_weight(problem, j, i, thetas[i]))
            logdet += float(np.linalg.slogdet(F)[1])
            after.append(_linear_band_sd(problem, np.linalg.inv(F), frames))
        # No band at all (every wrap below the contact clearance: nothing to shrink) gives 0.
        shrink = float(1.0 - np.mean(after) / before) if before > 0 else 0.0
        out.append({"joint": j, "log_det": logdet, "expected_shrinkage": shrink})
    return out


def excite_joints(per_guide_sd_mu0: NDArray, max_joints: int = 3) -> list[int]:
    """Joints whose guide's ``mu(0)`` is undetermined (infinite sd), else the worst-determined few.

    ``per_guide_sd_mu0`` has shape (K,) (worst over tendons); guide ``k`` sits at joint ``k``.
    """
    sd = np.asarray(per_guide_sd_mu0, dtype=float)
    free = [int(k) + 1 for k in np.flatnonzero(~np.isfinite(sd))]
    if free:
        return free
    return [int(k) + 1 for k in np.argsort(-sd)[:max_joints]]


def measure_advice(study: TyingStudy, truth: NDArray, frames: NDArray, settings: StudySettings) -> list[dict]:
    """The advice checked against the truth: each candidate joint's label added, the law re-fitted and re-sampled.

    For each candidate joint ``j`` the per-guide law is fitted and sampled again with the
    extra labels ``ln T[1, j] - ln(T_true[j, j] + noise)``, and the band it gives over the
    intermediate joints is scored against the truth with the same sampler and frames as the
    report: its mean width, the share of the truth inside it, and its median's RMSE.

    Parameters
    ----------
    study : TyingStudy
        The per-guide study (its problem, its band, and residual noise per tendon [N]).
    truth : ndarray, shape (T, N, n)
        Joint-side truth [N]; read here only, never by a fit of the study itself.
    frames : ndarray of int
        Frames the band is evaluated on.
    settings : StudySettings
        Sampler settings and seed.

    Returns
    -------
    list of dict
        Per joint ``2..N-1``: ``joint``; ``band_width_mean`` [N] and ``measured_shrinkage`` (the
        fraction of the study's own band width removed, the measured counterpart of
        :func:`instrument_scores`' ``expected_shrinkage``); ``truth_coverage`` and ``rmse_n`` [N]
        of the band against the truth.
    """
    problem = study.problem
    rng = np.random.default_rng(settings.seed + 1000)
    layout = problem.layout
    C, d = layout.constraints()
    joints = list(range(2, problem.n_guides + 1))
    Ms, bs, thetas = [], [], []
    for j in joints:
        Xj = problem.joint_design(j)
        for i in range(problem.n_tendons):
            t1 = problem.inputs.actuator[:, j - 1, i]
            label = truth[:, j - 1, i] + rng.normal(0.0, problem.noise_n, size=len(t1))
            yj = np.log(t1) - np.log(np.maximum(label, 1e-6))
            wj = delta_method_weight(t1, label)
            sigma = study.sigma[i]
            M, b, _ = problem.quadratic(i, sigma)
            M = M + problem.precision(i, sigma, design=Xj, weight=wj)
            b = b + Xj.T @ (wj * yj) / sigma**2
            scale = np.sqrt(np.r_[problem.weight[:, i], wj] / np.mean(problem.weight[:, i]))
            X_all = np.vstack([problem.design, Xj]) * scale[:, None]
            y_all = np.r_[problem.log_drop[:, i], yj] * scale
            Ms.append(M)
            bs.append(b)
            thetas.append(constrained_lstsq(X_all, y_all, layout, 1e-10).x)
    # Every candidate's laws (one per tendon) in one batch of samplers: one stream, seeded by the study's seed.
    draws = settings.sample(Ms, bs, C, d, thetas, layout, settings.seed)
    base = study.band.mean_width()
    out = []
    for n, j in enumerate(joints):
        m = problem.n_tendons
        band = ambiguity_band(problem, draws[m * n : m * n + m], frames, seed=settings.seed)
        scores = band.scores(truth)
        shrink = float(1.0 - scores["band_width_mean"] / base) if base > 0 else 0.0
        out.append({"joint": j, **scores, "measured_shrinkage": shrink})
    return out


#: The check confirms the linearised advice when the advised joint's measured shrinkage is at least
#: this fraction of its expected one (and its estimate is no further from the truth).
CONFIRM_FRACTION = 0.5

#: The rule of :func:`judge_advice`, in words (the report and the JSON quote it).
CONFIRM_RULE = (
    f"the advice is confirmed when the measured band shrinkage at the advised joint is at least "
    f"{CONFIRM_FRACTION:g} of the linearised expectation and, with that joint's label, the estimate's "
    "RMSE against the simulator truth at the intermediate joints is no larger than without it"
)


def judge_advice(candidates: list[dict], check: list[dict] | None, baseline: dict | None) -> dict:
    """Whether the check against the truth confirms the linearised (D-optimal) advice.

    Parameters
    ----------
    candidates : list of dict
        :func:`instrument_scores`' output.
    check : list of dict or None
        :func:`measure_advice`' output; None without intermediate truth.
    baseline : dict or None
        :meth:`~tendon_id.identifiability.band.Band.scores` of the study's own band (no added label).

    Returns
    -------
    dict
        ``status`` (``"confirmed"``, ``"not confirmed"`` or ``"unchecked"``), ``linearised_joint``
        (the D-optimal one), ``expected_shrinkage`` there, ``recommended_joint`` (the linearised
        joint unless the check contradicts it, then None), ``measured_best_joint`` (the largest
        measured shrinkage that leaves the estimate no further from the truth, else the largest
        shrinkage), ``measured_shrinkage`` and ``rmse_n`` at the advised and at the best joint, and ``rule``.
    """
    advised = max(candidates, key=lambda c: c["log_det"])
    out = {
        "linearised_joint": int(advised["joint"]),
        "expected_shrinkage": float(advised["expected_shrinkage"]),
        "rule": CONFIRM_RULE,
        "confirm_fraction": CONFIRM_FRACTION,
    }
    if not check:
        return {**out, "status": "unchecked", "recommended_joint": int(advised["joint"]), "measured_best_joint": None}
    by_joint = {c["joint"]: c for c in check}
    at = by_joint[advised["joint"]]
    rmse0 = None if baseline is None else baseline.get("rmse_n")
    closer = lambda c: rmse0 is None or c["rmse_n"] is None or c["rmse_n"] <= rmse0  # noqa: E731
    confirmed = at["measured_shrinkage"] >= CONFIRM_FRACTION * advised["expected_shrinkage"] and closer(at)
    pool = [c for c in check if closer(c)] or check
    best = max(pool, key=lambda c: c["measured_shrinkage"])
    return {
        **out,
        "status": "confirmed" if confirmed else "not confirmed",
        "recommended_joint": int(advised["joint"]) if confirmed else None,
        "measured_shrinkage": float(at["measured_shrinkage"]),
        "rmse_n": at["rmse_n"],
        "measured_best_joint": int(best["joint"]),
        "measured_best_shrinkage": float(best["measured_shrinkage"]),
        "measured_best_rmse_n": best["rmse_n"],
        "measured_best_expected_shrinkage": float(
            next(c["expected_shrinkage"] for c in candidates if c["joint"] == best["joint"])
        ),
    }
