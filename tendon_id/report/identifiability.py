"""The identifiability report: one self-contained HTML page and its JSON (:doc:`/guide/identifiability`)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from tendon_id.atomic import write_json_atomic
from tendon_id.identifiability.analysis import IdentifiabilityResult
from tendon_id.identifiability.band import ambiguity_band
from tendon_id.identifiability.profile import THRESHOLD_95
from tendon_id.identifiability.spectrum import RANK_RTOL, WELL_DETERMINED_EIGENVALUE, WELL_DETERMINED_SD
from tendon_id.identifiability.summary import (
    advice_sentence,
    advice_table,
    profile_table,
    tendon_sentences,
    trust_sentences,
)
from tendon_id.report.html import HtmlPage, pyplot


def spectrum_figure(result: IdentifiabilityResult):
    """Fisher eigenvalues (log scale) of the tied and per-guide laws, per tendon."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.4))
    for ax, (tying, st) in zip(axes, result.studies.items()):
        floor = None
        for i, s in enumerate(st.spectra):
            # Numerically zero eigenvalues are drawn on a floor below the rank threshold.
            floor = max(s.eigenvalues[0], 1e-300) * (RANK_RTOL**2) * 1e-3
            ev = np.maximum(s.eigenvalues, floor)
            ax.semilogy(np.arange(1, len(ev) + 1), ev, "o-", ms=3, label=f"tendon {i + 1} (rank {s.rank}/{s.n_params})")
        if floor is not None:
            ax.axhline(floor * 1e3, color="k", ls=":", lw=1, label="rank threshold (zero below)")
        ax.axhline(
            WELL_DETERMINED_EIGENVALUE,
            color="C2",
            ls="--",
            lw=1,
            label=f"well determined above (sd ≤ {WELL_DETERMINED_SD:g})",
        )
        ax.set_title(f"{tying}: Fisher-information eigenvalues")
        ax.set_xlabel("eigen-direction (largest first)")
        ax.xaxis.get_major_locator().set_params(integer=True)
        # F = X^T W X / sigma^2: wraps [rad] squared, W [N^2] over sigma^2 [N^2], so per (friction coefficient)^2.
        ax.set_ylabel("eigenvalue [-] (per friction coefficient²)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    return fig


def profile_figure(result: IdentifiabilityResult):
    """Profile likelihoods: the tied law's A, B, mu(0), and each guide's mu(0) (per-guide, tendon 1)."""
    plt = pyplot()
    tied = result.studies["tied"]
    per = result.studies["per-guide"]
    fig, axes = plt.subplots(1, 4, figsize=(13, 3.2))
    for ax, kind in zip(axes[:3], ("A", "B", "mu0")):
        for i, profs in enumerate(tied.profiles):
            p = next(q for q in profs if q.name.startswith(kind + "_t"))
            ax.plot(p.values - p.estimate, p.delta, "o-", ms=3, label=f"tendon {i + 1} ({p.verdict})")
        ax.axhline(THRESHOLD_95, color="k", ls="--", lw=1)
        ax.set_title(f"tied {kind}")
        ax.set_xlabel(f"{kind} − estimate")
        ax.set_ylim(0, 3 * THRESHOLD_95)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6)
    axes[0].set_ylabel("Δ(−2 ln L)")
    ax = axes[3]
    for p in per.profiles[0]:
        if p.name.startswith("mu0"):
            style = ":" if p.verdict.startswith("structurally") else "-"
            ax.plot(p.values, p.delta, style, lw=1, label=p.name.split("_")[1])
    ax.axhline(THRESHOLD_95, color="k", ls="--", lw=1)
    ax.set_ylim(0, 3 * THRESHOLD_95)
    ax.set_title("per-guide mu(0), tendon 1 (dotted: structural)")
    ax.set_xlabel("mu(0) = A + B")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=5, ncol=2)
    return fig


def posterior_figure(result: IdentifiabilityResult):
    """Tied posterior draws of (A, B) per tendon: the sloppy A − B ridge at a tight A + B."""
    plt = pyplot()
    tied = result.studies["tied"]
    m = len(tied.draws)  # one panel per tendon, then the per-guide correlations
    fig, axes = plt.subplots(1, m + 1, figsize=(13 * (m + 1) / 4, 3.2))
    for i, ax in enumerate(axes[:m]):
        d = tied.draws[i]
        ax.plot(d[:, 0], d[:, 1], ".", ms=1.5, alpha=0.4)
        ax.set_xlabel("A [-]")
        ax.set_ylabel("B [-]")
        ax.set_title(f"tendon {i + 1}: corr(A, B) = {tied.correlation(i)[0, 1]:.4f}")
        ax.grid(alpha=0.3)
    ax = axes[m]
    c = result.studies["per-guide"].correlation(0)
    im = ax.imshow(c, cmap="RdBu_r", vmin=-1, vmax=1)
    ax.set_title("per-guide posterior correlation, tendon 1", fontsize=8)
    k = c.shape[0] // 2
    ax.set_xticks([0, k - 1, k, 2 * k - 1], ["A_g1", f"A_g{k}", "B_g1", f"B_g{k}"], fontsize=6)
    ax.set_yticks([0, k - 1, k, 2 * k - 1], ["A_g1", f"A_g{k}", "B_g1", f"B_g{k}"], fontsize=6)
    fig.colorbar(im, ax=ax, fraction=0.046)
    return fig


def excitation_figure(result: IdentifiabilityResult):
    """Wrap range per guide (5–95 % box, min–max whisker) and correlation with the next guide."""
    plt = pyplot()
    cov = result.excitation
    g = np.array([c["guide"] for c in cov])
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11, 3.2))
    ax.vlines(g, [c["min_deg"] for c in cov], [c["max_deg"] for c in cov], color="0.5")
    ax.vlines(g, [c["p5_deg"] for c in cov], [c["p95_deg"] for c in cov], lw=8, color="C0", alpha=0.7)
    ax.set_xlabel("guide k")
    ax.set_ylabel("wrap alpha_k [deg]")
    ax.set_title("excitation: range of wraps seen (box 5–95 %, line min–max)")
    ax.grid(alpha=0.3)
    corr = [np.nan if c["corr_next"] is None else c["corr_next"] for c in cov]
    ax2.bar(g, corr, color="C1")
    ax2.set_ylim(-1, 1)
    ax2.set_xlabel("guide k")
    ax2.set_ylabel("corr(alpha_k, alpha_k+1)")
    ax2.set_title("correlation with the next guide (blank: constant wrap)")
    ax2.grid(alpha=0.3)
    return fig


def band_figure(result: IdentifiabilityResult, truth: np.ndarray | None, joint: int, window: int = 400):
    """The ambiguity band of one joint over a contiguous window, tied against per-guide, with truth."""
    plt = pyplot()
    tied, per = result.studies["tied"], result.studies["per-guide"]
    inputs = tied.problem.inputs
    start = 0
    frames = np.arange(start, min(start + window, inputs.n_frames))
    t = inputs.clock[frames]
    m = inputs.n_tendons  # one panel per tendon
    fig, axes = plt.subplots(1, m, figsize=(13 * m / 3, 3.3), sharey=False)
    bands = {
        name: ambiguity_band(st.problem, st.draws, frames, seed=result.settings.seed)
        for name, st in (("tied", tied), ("per-guide", per))
    }
    for i, ax in enumerate(axes):
        for name, color in (("per-guide", "C1"), ("tied", "C0")):
            b = bands[name]
            ax.fill_between(
                t, b.lo[:, joint - 1, i], b.hi[:, joint - 1, i], color=color, alpha=0.35, label=f"{name} 95 % band"
            )
        if truth is not None:
            ax.plot(t, truth[frames, joint - 1, i], "k", lw=1, label="truth")
        ax.set_title(f"joint {joint}, tendon {i + 1}")
        ax.set_xlabel("t [s]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("joint-side tension [N]")
    axes[-1].legend(fontsize=7)
    return fig


def band_width_figure(result: IdentifiabilityResult):
    """Mean band width per joint, tied against per-guide, and the truth coverage where known."""
    plt = pyplot()
    tied, per = result.studies["tied"].band, result.studies["per-guide"].band
    n = result.n_modules
    j = np.arange(1, n + 1)
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11, 3.2))
    ax.bar(j - 0.2, tied.per_joint_width(), width=0.4, label="tied")
    ax.bar(j + 0.2, per.per_joint_width(), width=0.4, label="per-guide")
    ax.set_xlabel("joint j")
    ax.set_ylabel("mean 95 % band width [N]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    if result.coverage is not None:
        ax2.plot(j[1:-1], result.coverage["tied"][1:-1], "o-", label="tied")
        ax2.plot(j[1:-1], result.coverage["per-guide"][1:-1], "s-", label="per-guide")
        ax2.axhline(0.95, color="k", ls="--", lw=1, label="nominal 95 %")
        ax2.set_ylim(0, 1.02)
        ax2.set_xlabel("joint j")
        ax2.set_ylabel("truth inside the band")
        ax2.legend(fontsize=8)
        ax2.grid(alpha=0.3)
    else:
        _no_truth(ax2)
    return fig


def _no_truth(ax) -> None:
    """An empty panel that says why it is empty."""
    ax.text(0.5, 0.5, "no intermediate truth in this data", ha="center", va="center")
    ax.set_axis_off()


def advice_figure(result: IdentifiabilityResult):
    """D-criterion per candidate joint; expected (linearised) against measured band shrinkage; RMSE against truth."""
    plt = pyplot()
    c = result.instrument
    v = result.advice_verdict
    j = np.array([x["joint"] for x in c])
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.2))
    ax = axes[0]
    ax.bar(j, [x["log_det"] for x in c], color=["C3" if x == v["linearised_joint"] else "C0" for x in j])
    ax.set_ylim(min(x["log_det"] for x in c) - 5, max(x["log_det"] for x in c) + 5)
    ax.set_xlabel("joint to instrument")
    ax.set_ylabel("sum of log det(F) (D-criterion)")
    ax.set_title("linearised D-optimal joint (red)")
    ax.grid(alpha=0.3)
    ax = axes[1]
    ax.plot(j, [100 * x["expected_shrinkage"] for x in c], "o-", label="expected (linearised)")
    check = result.advice_check
    if check:
        ax.plot([x["joint"] for x in check], [100 * x["measured_shrinkage"] for x in check], "s-", label="measured")
        ax.axhline(0, color="k", lw=0.8)
    ax.set_xlabel("joint to instrument")
    ax.set_ylabel("per-guide band narrower by [%]")
    ax.set_title("the advice's expectation, and its check" if check else "expectation (unchecked: no truth)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax = axes[2]
    if check and result.advice_baseline is not None:
        ax.plot(
            [x["joint"] for x in check], [x["rmse_n"] for x in check], "s-", color="C1", label="with the joint's label"
        )
        ax.axhline(result.advice_baseline["rmse_n"], color="k", ls="--", lw=1, label="terminal labels only")
        ax.set_xlabel("joint to instrument")
        ax.set_ylabel("RMSE against truth, joints 2..N-1 [N]")
        ax.set_title("the estimate against the simulator truth")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    else:
        _no_truth(ax)
    return fig


def _profile_section(page: HtmlPage, result: IdentifiabilityResult, fitted: str) -> None:
    """The informative profiles in view, the structurally flat ones counted, all of them folded."""
    t = profile_table(result, fitted)
    page.table(t["header"], t["shown"])
    page.paragraph(
        f"Shown: every tied profile, and the {t['finite']} per-guide ones with a finite interval. Not shown: "
        f"{t['flat']} of the per-guide law's {t['per_guide']} profiles are structurally unidentifiable (flat: the "
        f"terminal data cannot see them at all) and {t['open']} practically unidentifiable (open to the physical "
        "limit). Threshold 3.84 (95 %, Raue et al. 2009); the physical limit is mu ≥ 0 on [0, pi] and the sanity "
        "bounds.",
        cls="note",
    )
    page.table(t["header"], t["all"], collapsed=f"All {len(t['all'])} profiles (reference)")


def _determined_section(page: HtmlPage, result: IdentifiabilityResult, js: dict, fitted: str) -> None:
    """Rank, the unidentifiable directions, and the well-determined and sloppy combinations."""
    t, p = js["tied"], js["per_guide"]
    law = result.truth_law
    page.paragraph(
        f"Tied law (one (A_i, B_i) per tendon): rank {t['rank']} of {t['n_params']} "
        f"({'full rank' if t['rank'] == t['n_params'] else 'rank-deficient'}), Fisher condition number "
        f"{t['condition_number_identifiable']:.3g}. Per-guide law (one (A, B) per guide and tendon): rank "
        f"{p['rank']} of {p['n_params']}: {p['n_unidentifiable']} directions the terminal data cannot see at all."
    )
    for w in p["unidentifiable"]:
        page.paragraph("Unidentifiable: " + w, cls="note")
    page.heading("Well-determined and sloppy combinations", level=3)
    for text in tendon_sentences(result, fitted):
        page.paragraph(text)
    if law and not law["feasible"]:
        page.paragraph(
            "The truth's (A, B) has B < |A|, outside the fit's feasible set B ≥ |A| (mu ≥ 0 on [0, pi]): "
            "the fit can match its mu(0) but never its A and B.",
            cls="note",
        )
    good = t["well_determined"] + p["well_determined"]
    page.paragraph(
        f"Well determined ({t['n_well_determined']} tied, {p['n_well_determined']} per-guide directions): "
        + ("; ".join(good) if good else "none")
        + ".",
    )
    page.paragraph(
        f"Sloppy, identifiable but loose ({t['n_sloppy']} tied, {p['n_sloppy']} per-guide; the sloppiest): "
        + "; ".join(t["sloppy"][:3] + p["sloppy"][:3])
        + ".",
    )
    page.paragraph(
        f"Well determined: a Fisher eigen-direction whose unit-norm combination has a linearised sd of at most "
        f"{WELL_DETERMINED_SD:g} (eigenvalue at least {WELL_DETERMINED_EIGENVALUE:g}); each is written with its "
        "largest coefficient 1 and its sd as written. The sds are the fitted law's.",
        cls="note",
    )


def _advice_section(page: HtmlPage, result: IdentifiabilityResult, js: dict) -> None:
    """The advice with its check: expected against measured shrinkage per candidate, and the verdict's rule."""
    adv = js["advice"]
    v = adv["verdict"]
    page.paragraph(advice_sentence(result)["text"])
    page.paragraph(
        f"Excite joints {', '.join(map(str, adv['excite_joints']))}: their guides' mu(0) is the least determined "
        "(undetermined where the data held them still)."
    )
    header, rows = advice_table(js)
    check, base = adv["check"], adv["check_baseline"]
    page.table(header, rows)
    if check:
        rule = v["rule"][0].upper() + v["rule"][1:]
        page.paragraph(
            "Measured: each candidate joint's label (simulator truth plus load-cell noise) added to the terminal "
            "labels, the per-guide law sampled again, and its band scored against the truth (mean width against the "
            f"{base['band_width_mean']:.2f} N of the terminal labels alone, coverage and its median's RMSE over the "
            f"intermediate joints). {rule}. The measured best is the largest measured narrowing among the joints "
            "that leave the estimate no further from the truth.",
            cls="note",
        )
    else:
        page.paragraph(
            "Unchecked: without intermediate truth the advice is the linearised expectation only "
            "(the Fisher information of the joint's labels at the fitted law).",
            cls="note",
        )
    page.figure(advice_figure(result), "Which joint to instrument: the linearised expectation and its check.")


def report_page(result: IdentifiabilityResult) -> HtmlPage:
    """Build the report page of one identifiability result (:func:`~tendon_id.identifiability.analyse`)."""
    js = result.to_dict()
    tied, per = result.studies["tied"], result.studies["per-guide"]
    mis = js["misspecification"]["misspecified"]
    fitted = "fitted" if not mis else "fitted (misspecified)"
    source = f"; file {Path(result.source).name}" if result.source else ""
    page = HtmlPage(
        f"Identifiability: {result.name}",
        subtitle=f"{result.n_frames} frames, N = {result.n_modules}{source}. Structure analysed: {result.model_name}, "
        f"fitted on the terminal labels only.",
        made_by=f"tendon_id.identifiability.analyse, {result.seconds:.0f} s",
    )
    for s in js["summary"]:
        page.lead(s["text"], s["tone"])

    page.heading("How far to trust the numbers")
    for text in trust_sentences(result):
        page.paragraph(text)

    page.heading("What this data determines" + (" about the misspecified fit" if mis else ""))
    _determined_section(page, result, js, "fitted")
    page.figure(
        spectrum_figure(result),
        "Fisher-information eigen-spectrum" + (" of the misspecified fit" if mis else "") + ": the per-guide law's "
        "eigenvalues fall off a cliff where the data is blind (structural), and spread over many decades where it "
        "is sloppy.",
    )

    page.heading("Profile likelihoods")
    _profile_section(page, result, fitted)
    page.figure(profile_figure(result), f"Profile likelihoods of the {fitted} law with the 95 % threshold (dashed).")

    page.heading("Posterior widths and correlations")
    if result.emcee is not None:
        e = result.emcee
        page.paragraph(
            f"emcee (tied, cross-check of the exact hit-and-run draws): corr(A, B) per tendon "
            f"{', '.join(f'{c:.4f}' for c in e['corr_A_B'])}; {fitted} sd of mu(0) "
            f"{', '.join(f'{s:.2g}' for s in e['mu0_sd'])}; autocorrelation time {e['tau']:.0f} steps, "
            f"{e['seconds']:.1f} s."
        )
    page.paragraph(
        f"Hit-and-run convergence, largest split R-hat of mu(0) per tendon: tied "
        f"{', '.join(f'{r:.3f}' for r in tied.rhat)}, per-guide {', '.join(f'{r:.3f}' for r in per.rhat)} "
        "(values above 1.1 mean the flat per-guide directions were explored only roughly).",
        cls="note",
    )
    page.figure(posterior_figure(result), f"Tied (A, B) draws ({fitted}), and the per-guide posterior correlation.")

    page.heading("Excitation coverage")
    page.table(
        ["guide", "min [deg]", "max [deg]", "sd [deg]", "distinct readings", "corr with next"],
        [
            [c["guide"], c["min_deg"], c["max_deg"], c["sd_deg"], c["distinct"]]
            + ["constant" if c["corr_next"] is None else c["corr_next"]]
            for c in result.excitation
        ],
    )
    page.figure(excitation_figure(result), "What each guide saw.")

    page.heading("Intermediate-tension ambiguity band")
    b = js["bands"]
    page.paragraph(
        f"Mean 95 % band over the intermediate joints: tied {b['tied_width_mean']:.2f} N, per-guide "
        f"{b['per_guide_width_mean']:.2f} N (laws that fit the terminal data equally well, plus the actuator load "
        "cell's noise)" + (": the misspecified fit's ambiguity, not the error against the robot." if mis else ".")
    )
    page.figure(band_width_figure(result), "Band width per joint, and the share of frames whose truth it covers.")
    page.figure(
        band_figure(result, result.truth, joint=max(2, result.n_modules // 2)),
        "The band of a middle joint over the first frames, tied against per-guide.",
    )

    page.heading("Advice: what to measure next")
    _advice_section(page, result, js)

    if result.learned is not None:
        page.heading("The learned cascade: tied against per-guide PG-CHTC")
        rows = [
            [name, d["seeds"], "-" if d["joint_rmse_mean"] is None else d["joint_rmse_mean"], d["seed_spread_mean_n"]]
            for name, d in result.learned.items()
        ]
        page.table(["PG-CHTC", "seeds", "intermediate-joint RMSE [N]", "spread across seeds [N]"], rows)
    return page


def write_report(
    result: IdentifiabilityResult, out: str | os.PathLike, json_path: str | os.PathLike | None = None
) -> Path:
    """Write the HTML page (and the JSON summary) atomically."""
    path = report_page(result).write(out)
    if json_path is not None:
        write_json_atomic(json_path, result.to_dict())
    return path
