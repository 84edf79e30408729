"""Table III's page: closed-loop step responses like the paper's Fig. 6, and the table beside the paper's."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from tendon_id.report.closed_loop_chain import CHAIN_HEADER, chain_figure, chain_rows
from tendon_id.report.closed_loop_lead import TERMS, lead_sentences
from tendon_id.report.html import HtmlPage, pyplot
from tendon_id.zoo.guard import guard_fired

#: The paper's colours (Fig. 6: PG-CHTC blue, the Capstan baseline red); the others muted.
COLOURS = {
    "pg-chtc": "tab:blue",
    "capstan-nonsmooth": "tab:red",
    "pg-chtc-ns": "tab:purple",
    "proximal": "tab:gray",
    "oracle": "k",
}


def step_figure(traces: dict, regime: str, rows: list[dict] | None = None):
    """Fig. 6 for one regime: the stepped joints' ``theta_x`` and ``theta_y`` of each estimator.

    A planar robot's (``bending_axes`` 1 in the traces) ``theta_y`` is zero throughout: ``theta_x`` alone.
    Dashed black: the commanded amplitude, and the shaped reference. Vertical dotted lines: the
    rise (10-90 %) and settling times of PG-CHTC and the Capstan baseline in seed 0's run.
    """
    plt = pyplot()
    tr = traces[regime]
    t = np.asarray(tr["t"])
    ref = np.asarray(tr["ref_deg"])  # (F, joints, 2)
    ang = np.asarray(tr["angles_deg"])  # (E, F, joints, 2)
    planes = ((0, r"$\theta_x$"), (1, r"$\theta_y$"))[: tr.get("bending_axes", 2)]
    fig, axes = plt.subplots(1, len(planes), figsize=(6 * len(planes), 4.2), sharey=True, squeeze=False)
    axes = axes[0]
    for ax, (axis, label) in zip(axes, planes):
        for e, name in enumerate(tr["estimators"]):
            colour = COLOURS.get(name, None)
            width = 1.6 if name in ("pg-chtc", "capstan-nonsmooth") else 0.9
            for j in range(ang.shape[2]):
                ax.plot(t, ang[e, :, j, axis], color=colour, lw=width, alpha=0.85, label=name if j == 0 else None)
        ax.plot(t, ref[:, 0, axis], "k--", lw=1.0, label="reference")
        amp = tr["amplitude_deg"] * tr["direction"][axis]
        ax.axhline(amp, color="k", ls=":", lw=0.8)
        for r in rows or []:
            if r["regime"] != regime or r["estimator"] not in ("pg-chtc", "capstan-nonsmooth"):
                continue
            start = tr["lead_s"] + (r["loop"] - 1) * tr["hold_s"]
            if r.get("settle_s") is not None:
                ax.axvline(start + r["settle_s"], color=COLOURS[r["estimator"]], ls=":", lw=1.0)
        ax.set_xlabel("time [s]")
        ax.set_title(f"{label} of joints {tr['joints'][0]}-{tr['joints'][-1]}", fontsize=10)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("joint angle [deg]")
    axes[-1].legend(fontsize=8, loc="upper right")
    fig.suptitle(f"Closed loop at 10 Hz, {regime}: 0 -> {tr['amplitude_deg']:g} deg -> 0", fontsize=11)
    fig.tight_layout()
    return fig


def _cell(r: dict, key: str) -> str:
    v = r[key]
    if v is None:
        return f"never ({r[f'{key}_reached']}/{r['seeds']} seeds)" if r["seeds"] > 1 else "never"
    if r["seeds"] == 1:  # one seed has no spread to show
        return f"{v:.2f}"
    return f"{v:.2f}\u00a0±\u00a0{r[f'{key}_sd']:.2f}"  # no-break spaces: one line per cell


def write_table3_page(
    result: dict,
    path: str | os.PathLike,
    made_by: str = "tendon-id benchmark table3 --out PAGE",
    open_loop: dict[str, float] | None = None,
) -> Path:
    """Write Table III and its figures as one self-contained HTML page; returns its path.

    ``open_loop``, estimator name to its open-loop intermediate-joint RMSE [N], lets the page
    say where the closed-loop ranking differs from the open-loop one.
    """
    page = HtmlPage(f"Closed loop: the estimator in a 10 Hz hybrid controller ({result['recipe']})", made_by=made_by)
    for text, tone in lead_sentences(result, open_loop):
        page.lead(text, tone)
    page.paragraph(
        "Each estimator drives its own simulated robot (joint dynamics at 1 kHz through the recipe's truth "
        "transmission, stick/slip state carried) in the paper's step-and-return tests, with controller gains "
        "tuned once for the oracle. Rise is 10-90 % of the step, settling is on the ±0.5° band, RMS is the "
        + (
            f"tracking error; mean ± sd over {result['repeats']} seeds (step direction, sensor noise)."
            if result["repeats"] > 1
            else "tracking error; one seed (step direction, sensor noise)."
        )
    )
    first_seed = min(r["seed"] for r in result["runs"])  # the seed whose traces the result keeps
    first_runs = [r for r in result["runs"] if r["seed"] == first_seed]
    for regime in result["traces"]:
        page.figure(
            step_figure(result["traces"], regime, first_runs),
            f"{regime}, the first seed: PG-CHTC in blue, the Capstan baseline in red; dotted verticals mark "
            "their settling times, the dotted horizontal the commanded amplitude.",
        )
    rows = []
    for r in result["rows"]:
        p = r["paper"]
        rows.append(
            [r["regime"], r["estimator"], r["loop"], _cell(r, "rise_s"), _cell(r, "settle_s"), _cell(r, "rms_deg")]
            + [f"{p['rise_s']:.2f} / {p['settle_s']:.2f} / {p['rms_deg']:.2f}" if p else "-"]
            + [
                f"{r['why']['estimate_rmse_n']:.1f}",
                f"{r['why']['estimate_bias_n']:+.1f}",
                f"{r['why']['torque_error_nm']:.3f}",
                f"{r['why']['stick_fraction']:.2f}",
            ]
        )
    page.heading("Table III, ours beside the paper's")
    page.table(
        [
            "regime",
            "estimator",
            "loop (1 step, 2 return)",
            "rise [s]",
            "settle [s]",
            "RMS [°]",
            "paper: rise / settle / RMS",
            "estimate RMSE [N]",
            "estimate bias [N]",
            "torque error [N m]",
            "stick share",
        ],
        rows,
    )
    page.paragraph(TERMS)
    fig = chain_figure(result["rows"], COLOURS)
    if fig is not None:
        page.heading("What intermediate accuracy buys")
        page.figure(
            fig,
            "Each estimator's settling time (left) and RMS tracking error (right) against the RMSE of its "
            "intermediate estimates, every set's tension at the joints it passes through (k < j), in the same "
            "runs; circles loop 1, squares loop 2; filled and open markers the two regimes.",
        )
        page.table(CHAIN_HEADER, chain_rows(result["rows"]))
        page.paragraph(
            "The pass-through load error is the RMS, over joints and samples, of the moment error those "
            "intermediate estimates imply about every joint: what the controller's feedforward gets wrong.",
            cls="note",
        )
    page.paragraph(
        "The last four columns say why: the estimator's joint-side error at the stepped joints during the loop "
        "(against the simulator's truth), the RMS error of the joint torque that estimate implies (what the "
        "configuration loop feels: a bias common to a joint's tendons spread evenly exerts none), and the fraction "
        "of the stepped sets' guide passages in stick.",
        cls="note",
    )
    guards = [g for g in result.get("guards", []) if guard_fired(g)]
    if guards:
        page.paragraph(
            "The prior guard fired for: "
            + "; ".join(f"{g['method']} ({g['cascade_rmse']:.3g} N against {g['prior_rmse']:.3g} N)" for g in guards),
            cls="warning",
        )
    page.paragraph(
        f"Preset {result['preset']}, built in {result['seconds']:.0f} s (fitting {result['fit_seconds']:.0f} s).",
        cls="note",
    )
    return page.write(path)
