"""The diagnosis report: one self-contained HTML page (gap map, ranking, ladder, residual plots) and its JSON."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from tendon_id.atomic import write_json_atomic
from tendon_id.diagnosis.result import DiagnosisResult
from tendon_id.report.diagnosis_lead import lead_sentences, truth_rows
from tendon_id.report.html import HtmlPage, pyplot


def gap_map_figure(result: DiagnosisResult):
    """Share of squared error against share of frames, per stratum (bars above the line: the gap sits there)."""
    plt = pyplot()
    rows = result.where
    fig, ax = plt.subplots(figsize=(10, 0.22 * len(rows) + 1.2))
    y = np.arange(len(rows))[::-1]
    ax.barh(y + 0.2, [r.share_error for r in rows], height=0.4, color="tab:red", label="share of squared error")
    ax.barh(y - 0.2, [r.share_frames for r in rows], height=0.4, color="tab:gray", label="share of frames")
    ax.set_yticks(y, [r.stratum for r in rows], fontsize=7)
    ax.set_xlabel("share [-]")
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(axis="x", alpha=0.3)
    ax.set_title("Where the base's held-out error lies")
    fig.tight_layout()
    return fig


def null_gain_lines(result) -> list[str]:
    """Where the paired test decided: what each paired model gained on simulated null data, and on these frames."""
    mse0 = result.base_rmse**2
    parts = []
    for g in result.null_gains:
        rung = next((r for r in result.ladder if list(r.effects[1:]) == list(g.effects)), None)
        if rung is None:
            continue
        parts.append(
            f"{' + '.join(g.effects)} lowered the base's mean squared error by {np.expm1(np.mean(g.log_ratios)):.1%} "
            f"on average there, so its margin is {g.margin:.1%} ({g.scale:g} times the {g.level:.3g} prediction "
            f"bound in log); on these frames it lowers it by {mse0 / rung.heldout_rmse**2 - 1.0:.1%}"
        )
    if not parts:
        return []
    draws = len(result.null_gains[0].log_ratios)
    return [
        f"The floor alone shows no gap, so the paired test decides, against what a refit gains on {draws} draws of "
        "data simulated from the base's fit (the base is the truth there): " + "; ".join(parts) + "."
    ]


def ladder_figure(result: DiagnosisResult):
    """The ladder as a waterfall: held-out RMSE after each added effect, with the noise floor."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 3.2))
    rmse = [r.heldout_rmse for r in result.ladder]
    labels = ["base"] + [f"+ {r.effects[-1]}" for r in result.ladder[1:]]
    for k in range(len(rmse)):
        top = rmse[k - 1] if k else rmse[0]
        bottom = rmse[k] if k else 0.0
        ax.bar(k, top - bottom, bottom=bottom, color="tab:blue" if k == 0 else "tab:green")
        ax.text(k, rmse[k], f"{rmse[k]:.3g} {result.unit}", ha="center", va="bottom", fontsize=8)
    floor = f"noise floor {result.noise_floor:.3g} {result.unit}"
    ax.axhline(result.noise_floor, color="k", ls="--", lw=1, label=floor)
    ax.set_xticks(range(len(rmse)), labels, fontsize=8)
    ax.set_ylabel(f"held-out RMSE [{result.unit}]")
    ax.legend(fontsize=8)
    ax.set_title("How far the gap shrinks")
    fig.tight_layout()
    return fig


def residual_figure(result: DiagnosisResult):
    """The base's held-out residual against the leading candidates' signature regressors."""
    plt = pyplot()
    cols = [k for k in result.plots if k != "residual"]
    if not cols:
        return None
    cols = cols[:6]
    fig, axes = plt.subplots(1, len(cols), figsize=(3.2 * len(cols), 3.0), squeeze=False)
    e = result.plots["residual"]
    corr = result.cross_correlation
    for ax, label in zip(axes[0], cols):
        ax.plot(result.plots[label], e, ".", ms=1.5, alpha=0.4)
        ax.set_title(f"{label}\ncorrelation {corr.get(label, float('nan')):+.2f}", fontsize=8)
        ax.set_xlabel(f"signature regressor [{result.unit}]", fontsize=8)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel(f"base residual [{result.unit}]")
    fig.tight_layout()
    return fig


def report_page(result: DiagnosisResult) -> HtmlPage:
    page = HtmlPage(
        f"Sim-to-real gap diagnosis of {result.base}",
        subtitle="Where the model's held-out error lies, which unmodelled effect explains it, and how far it shrinks.",
        made_by="tendon-id diagnose",
        contents=True,
    )
    u = result.unit
    for text, tone in lead_sentences(result):
        page.lead(text, tone)
    if result.truth is not None:
        page.heading("The finding beside the simulator's truth")
        page.table(["effect", "in the truth", "in the base", "gap closed as a candidate", "named"], truth_rows(result))
    page.heading("The gap")
    page.paragraph(
        f"Held-out RMSE of the base {result.base_rmse:.3g} {u} against a noise floor of "
        f"{result.noise_floor:.3g} {u} (upper quantile: {result.noise_floor_upper:.3g} {u}; "
        f"{result.noise_source}); {result.validation}, {result.n_heldout} held-out frames. "
        f"Ljung–Box p-values of the base residual per tendon (lag {result.whiteness.get('lags')}): "
        + ", ".join(("< 0.001" if p < 1e-3 else f"{p:.2g}") for p in result.whiteness.get("ljung_box_p", []))
        + " (small: the residual is not white, something systematic is left).",
        cls="note",
    )
    for line in null_gain_lines(result):
        page.paragraph(line, cls="note")
    for w in result.warnings:
        page.paragraph(f"Warning: {w}", cls="warning")
    page.heading("Where")
    page.figure(gap_map_figure(result), "Share of the held-out squared error and of the frames, per stratum.")
    page.table(
        ["stratum", "share of error", "share of frames", f"bias [{u}]", f"bias 95 % interval [{u}]"],
        [
            [s.stratum, s.share_error, s.share_frames, s.bias, f"{s.bias_ci[0]:.3g} … {s.bias_ci[1]:.3g}"]
            for s in result.top_strata(12)
        ],
    )
    page.heading("Which")
    page.table(
        ["effect", "where", f"held-out RMSE [{u}]", "gap closed", "significant", "ΔBIC (train)", "fitted parameters"],
        [
            [
                c.effect,
                c.location,
                c.heldout_rmse,
                f"{c.gap_closed:.0%}",
                "yes" if c.significant else "no",
                c.ic_delta,
                ", ".join(f"{k}={v:.3g}" for k, v in c.params.items()),
            ]
            for c in result.candidates
        ],
    )
    if result.skipped:
        page.paragraph("Not tried: " + "; ".join(f"{k} ({v})" for k, v in result.skipped.items()) + ".", cls="note")
    agree = "agrees with" if result.vote_agrees else "differs from"
    page.paragraph(
        f"Sparse regression of the residual on the signature library (pysindy STLSQ) votes {result.vote}; "
        f"it {agree} the ranking by refits.",
        cls="note",
    )
    fig = residual_figure(result)
    if fig is not None:
        page.figure(fig, "The base's held-out residual against the signature regressors of the leading candidates.")
    page.heading("How far")
    page.figure(ladder_figure(result), "Held-out RMSE after each effect the ladder adds.")
    page.table(
        ["rung", f"held-out RMSE [{u}]", "gap closed"],
        [[" + ".join(r.effects), r.heldout_rmse, f"{r.gap_closed:.0%}"] for r in result.ladder],
    )
    page.paragraph(f"Diagnosed in {result.seconds:.0f} s.", cls="note")
    return page


def write_report(result: DiagnosisResult, out: str | os.PathLike, json_path: str | os.PathLike | None = None) -> Path:
    """Write the HTML page (and the JSON) atomically."""
    path = report_page(result).write(out)
    if json_path is not None:
        write_json_atomic(json_path, result.to_dict())
    return path
