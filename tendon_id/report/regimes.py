"""The regime map's page: heat maps of each learned cascade's RMSE ratio to calibrated capstan-nonsmooth."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from tendon_id.report.html import HtmlPage, pyplot
from tendon_id.zoo.guard import guard_fired, worse_kinds_text

#: The learned models of the map, in column order (the physics baseline is the denominator).
LEARNED = ("pg-chtc", "pg-chtc-ns")


def _grid(result: dict, key: str) -> tuple[list[str], list[str], np.ndarray]:
    """Ratios ``key`` as (settings, columns, array (settings, columns)); columns are model x session."""
    cells = result["cells"]
    settings = list(dict.fromkeys(c["setting"] for c in cells))
    sessions = list(dict.fromkeys(c["session"] for c in cells))
    columns = [f"{m}\n{s}" for s in sessions for m in LEARNED]
    out = np.full((len(settings), len(columns)), np.nan)
    for c in cells:
        base = c["methods"]["capstan-nonsmooth"][key]["rmse"]
        for m in LEARNED:
            col = columns.index(f"{m}\n{c['session']}")
            out[settings.index(c["setting"]), col] = c["methods"][m][key]["rmse"] / base
    return settings, columns, out


def regime_heatmap(result: dict):
    """Two heat maps (terminal joint, intermediate joints): ratio to capstan-nonsmooth, blue where learning wins."""
    plt = pyplot()
    from matplotlib.colors import LogNorm

    fig, axes = plt.subplots(1, 2, figsize=(12, 0.5 * len(set(c["setting"] for c in result["cells"])) + 2.2))
    norm = LogNorm(vmin=0.25, vmax=4.0)
    for ax, key, title in zip(axes, ("terminal", "joints"), ("terminal joint", "intermediate joints 2..N-1")):
        settings, columns, ratio = _grid(result, key)
        im = ax.imshow(np.clip(ratio, 0.25, 4.0), cmap="RdBu_r", norm=norm, aspect="auto")
        for (i, j), v in np.ndenumerate(ratio):
            ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=8, color="k" if 0.5 < v < 2 else "w")
        ax.set_xticks(range(len(columns)), labels=columns, fontsize=8)
        ax.set_yticks(range(len(settings)), labels=settings if ax is axes[0] else [], fontsize=8)
        ax.set_title(f"RMSE ratio to capstan-nonsmooth, {title}", fontsize=10)
    ticks = [0.25, 0.5, 1.0, 2.0, 4.0]
    bar = fig.colorbar(im, ax=axes, shrink=0.8, label="ratio (below 1: the learned cascade is better)", ticks=ticks)
    bar.ax.set_yticklabels([f"{t:g}" for t in ticks])
    bar.ax.minorticks_off()
    return fig


def lead_sentences(result: dict) -> list[tuple[str, str]]:
    """The map's first screen: in how many regimes learning wins at the intermediate joints, and how far to trust it."""
    settings, columns, ratio = _grid(result, "joints")
    out = []
    for k, column in enumerate(columns):
        col = ratio[:, k]
        wins = [s for s, r in zip(settings, col) if r < 1]
        name = column.replace("\n", " (") + " session)"
        out.append(
            (
                f"{name} beats calibrated capstan-nonsmooth at the intermediate joints in {len(wins)} of "
                f"{len(settings)} regimes (RMSE ratio {np.nanmin(col):.2f} to {np.nanmax(col):.2f}).",
                "verdict",
            )
        )
    out.append(
        (
            f"How far to trust it: one seed ({result['seed']}) and the {result['preset']} preset per cell, so a ratio "
            "a few percent from 1 may not hold over seeds.",
            "plain",
        )
    )
    return out


def write_regimes_page(result: dict, path: str | os.PathLike) -> Path:
    """Write the regime map as a self-contained HTML page; returns its path."""
    page = HtmlPage(
        f"Regime map: when does learning beat calibrated physics? ({result['recipe']})",
        made_by="tendon-id benchmark regimes --out PAGE",
    )
    for text, tone in lead_sentences(result):
        page.lead(text, tone)
    page.paragraph(
        "Each row is the recipe with one physical setting changed, each column a learned cascade in a session "
        "whose logs start where unlogged motion left them (continuous) or from forward slip (fresh). A cell is "
        "the learned cascade's held-out RMSE divided by calibrated capstan-nonsmooth's in the same regime: "
        "blue (below 1) where learning wins, red where the calibrated physics does."
    )
    page.figure(regime_heatmap(result), "Overall RMSE ratios (frame-weighted over the three test protocols).")
    rows = []
    for c in result["cells"]:
        m = c["methods"]
        best = min(m, key=lambda k: m[k]["terminal"]["rmse"])
        floor = c["floor"]["rmse"] if c.get("floor") else "-"
        rows.append(
            [c["setting"], c["session"]]
            + [m[k]["terminal"]["rmse"] for k in m]
            + [m[k]["joints"]["rmse"] for k in m]
            + [floor, best]
        )
    names = list(result["cells"][0]["methods"]) if result["cells"] else []
    page.heading("Overall RMSE [N]")
    page.table(
        ["setting", "session"]
        + [f"{n} terminal" for n in names]
        + [f"{n} joints" for n in names]
        + ["noise floor", "best at the terminal"],
        rows,
    )
    guards = [
        f"{c['setting']}, {c['session']}: {k} ({g['cascade_rmse']:.3g} N against {g['prior_rmse']:.3g} N"
        + (f"; worse on {worse_kinds_text(g)}" if worse_kinds_text(g) else "")
        + ")"
        for c in result["cells"]
        for k, m in c["methods"].items()
        if (g := m.get("guard")) and guard_fired(g)
    ]
    if guards:
        n_cells = len(result["cells"]) * len(LEARNED)
        page.lead(
            f"In {len(guards)} of {n_cells} cells a learned cascade validated worse than its own calibrated prior "
            "(the prior guard fired): there its ratio says more about the training than about the physics. "
            "They are listed under the table.",
            tone="warning",
        )
        page.paragraph(
            "The prior guard fired (validation RMSE worse than the calibrated prior's, pooled or on one kind "
            "of motion, which is named) in: " + "; ".join(guards) + ".",
            cls="warning",
        )
    f = result["cells"][0]["frames"] if result["cells"] else {}
    page.paragraph(
        f"Preset {result['preset']}, seed {result['seed']}, {len(result['cells'])} regimes, "
        f"{f.get('train', 0)} training and {f.get('val', 0)} validation frames each, built in "
        f"{result['seconds']:.0f} s.",
        cls="note",
    )
    return page.write(path)
