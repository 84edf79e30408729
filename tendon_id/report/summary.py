"""The recording summary page: wrap coverage, tension traces, actuator versus terminal."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tendon_id.data import Recording
from tendon_id.geometry import RobotGeometry, backbone_wrap
from tendon_id.report.html import HtmlPage, pyplot


def wrap_coverage_figure(recordings: Sequence[Recording]):
    """Box plot of the backbone wrap [deg] each guide saw, one colour per protocol."""
    plt = pyplot()
    n = recordings[0].n_modules
    fig, ax = plt.subplots(figsize=(9, 3.4))
    width = 0.8 / len(recordings)
    for r_i, rec in enumerate(recordings):
        alpha0 = (rec.meta.get("robot") or {}).get("alpha_0", RobotGeometry().alpha_0)
        wrap = np.rad2deg(backbone_wrap(rec.angles, alpha0))
        pos = np.arange(1, n) + (r_i - (len(recordings) - 1) / 2) * width
        bp = ax.boxplot(wrap, positions=pos, widths=width * 0.9, showfliers=False, patch_artist=True)
        color = plt.cm.tab10(r_i)
        for box in bp["boxes"]:
            box.set_facecolor(color)
            box.set_alpha(0.6)
        ax.plot([], [], color=color, lw=6, alpha=0.6, label=rec.protocol or f"recording {r_i}")
    ax.set_xticks(np.arange(1, n), labels=[str(k) for k in range(1, n)])
    ax.set_xlim(0.4, n - 0.4)
    ax.set_xlabel("guide k")
    ax.set_ylabel("backbone wrap alpha_k [deg]")
    ax.legend(fontsize=8, ncol=min(len(recordings), 4))
    ax.grid(alpha=0.3)
    return fig


def tension_trace_figure(rec: Recording, trajectory: str | None = None):
    """Actuator-side, intermediate truth and terminal tensions of one trajectory, per tendon."""
    plt = pyplot()
    traj = trajectory or rec.trajectories[0]
    mask = rec.trajectory_ids == traj
    t = rec.time[mask]
    n = rec.n_modules
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.2), sharey=True)
    truth = rec.joint_truth
    for i, ax in enumerate(axes):
        ax.plot(t, rec.actuator[mask, n - 1, i], color="k", lw=1.2, label=f"actuator T[1,{n}]")
        if truth is not None:
            for j in (n // 3, 2 * n // 3):
                ax.plot(t, truth[mask, j - 1, i], lw=0.9, alpha=0.8, label=f"joint {j} truth T[{j},{j}]")
        ax.plot(t, rec.terminal[mask, i], color="C3", lw=1.2, label=f"terminal T[{n},{n}]")
        ax.set_title(f"tendon {i + 1}")
        ax.set_xlabel("t [s]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("tension [N]")
    axes[-1].legend(fontsize=7)
    fig.suptitle(f"trajectory {traj}", fontsize=10)
    return fig


def actuator_vs_terminal_figure(rec: Recording):
    """Terminal joint-side against actuator-side tension of the terminal set, with the no-loss line."""
    plt = pyplot()
    n = rec.n_modules
    fig, ax = plt.subplots(figsize=(4.6, 4.2))
    for i in range(3):
        ax.plot(rec.actuator[:, n - 1, i], rec.terminal[:, i], ".", ms=1.5, alpha=0.4, label=f"tendon {i + 1}")
    hi = float(np.nanmax(rec.actuator[:, n - 1]))
    ax.plot([0, hi], [0, hi], "k--", lw=1, label="no loss (proximal)")
    ax.set_xlabel(f"actuator side T[1,{n}] [N]")
    ax.set_ylabel(f"terminal joint side T[{n},{n}] [N]")
    ax.legend(fontsize=7, markerscale=6)
    ax.grid(alpha=0.3)
    return fig


def summary_page(recordings: Sequence[Recording], title: str = "tendon-id recording summary") -> HtmlPage:
    """A page with a table of the recordings and the three standard figures."""
    page = HtmlPage(title)
    page.heading("Recordings")
    rows = []
    for rec in recordings:
        s = rec.describe()
        rows.append(
            [
                rec.protocol or "-",
                s["n_modules"],
                s["n_frames"],
                s["n_trajectories"],
                ", ".join(s.get("effects") or []) or "none",
                "yes" if rec.has_truth else "no",
                float(np.mean(rec.terminal)),
                float(np.mean(rec.actuator[:, -1])),
            ]
        )
    page.table(
        [
            "protocol",
            "modules",
            "frames",
            "trajectories",
            "effects",
            "intermediate truth",
            "mean terminal [N]",
            "mean actuator, set N [N]",
        ],
        rows,
    )
    page.heading("Wrap coverage per guide")
    page.figure(
        wrap_coverage_figure(recordings), "Backbone wrap alpha_k (paper Eq. (3)) seen by each guide, per protocol."
    )
    for rec in recordings:
        page.heading(f"Tension traces: {rec.protocol}")
        page.figure(
            tension_trace_figure(rec),
            "Actuator-side, intermediate joint-side truth and terminal joint-side tensions of one trajectory.",
        )
        page.figure(
            actuator_vs_terminal_figure(rec),
            "Terminal joint side against actuator side for the terminal set: "
            "the gap below the dashed line is the transmission loss.",
        )
    return page
