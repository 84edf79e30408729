"""The recording summary page: wrap coverage, tension traces, actuator versus terminal."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tendon_id.data import Recording
from tendon_id.geometry import backbone_wrap
from tendon_id.report.html import HtmlPage, pyplot


def wrap_coverage_figure(recordings: Sequence[Recording]):
    """Box plot of the wrap [deg] the joints gave each guide, one colour per protocol.

    Paper Eq. (3) without the routing wrap: what the joint angles show, on real data and
    simulated alike (a model fits the routing wrap; the metadata's is the simulator's truth).
    """
    plt = pyplot()
    n = recordings[0].n_modules
    fig, ax = plt.subplots(figsize=(9, 3.4), layout="constrained")
    width = 0.8 / len(recordings)
    for r_i, rec in enumerate(recordings):
        wrap = np.rad2deg(backbone_wrap(rec.angles, 0.0))
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
    ax.set_ylabel("bend wrap (|theta_k| + |theta_k+1|) / 2 [deg]")
    ax.legend(fontsize=8, ncol=min(len(recordings), 4))
    ax.grid(alpha=0.3)
    return fig


def tension_trace_figure(rec: Recording, trajectory: str | None = None):
    """Actuator side against joint side of the same set, for three sets along the chain, one trajectory.

    Each panel is one set ``j``: its actuator-side tensions ``T[1, j]`` (solid) and its joint-side
    tensions ``T[j, j]`` (dashed: the simulator's truth, or the measured terminal tension for the
    terminal set), so the drop between the two is that set's transmission loss.
    """
    plt = pyplot()
    traj = trajectory or rec.trajectories[0]
    mask = rec.trajectory_ids == traj
    t = rec.time[mask]
    n = rec.n_modules
    sets = (n // 3, 2 * n // 3, n) if rec.joint_truth is not None else (n,)
    fig, axes = plt.subplots(1, len(sets), figsize=(11, 3.4), sharey=True, layout="constrained", squeeze=False)
    for ax, j in zip(axes[0], sets):
        joint = rec.terminal[mask] if j == n else rec.joint_truth[mask, j - 1]
        for i in range(rec.n_tendons):
            label = f"tendon {i + 1}: actuator side T[1,j]"
            ax.plot(t, rec.actuator[mask, j - 1, i], color=f"C{i}", lw=1.2, label=label)
            ax.plot(t, joint[:, i], color=f"C{i}", lw=1.0, ls="--", label=f"tendon {i + 1}: joint side T[j,j]")
        ax.set_title(f"set {j}" + (" (terminal, measured)" if j == n else " (joint side: simulator truth)"), fontsize=9)
        ax.set_xlabel("t [s]")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("tension [N]")
    fig.legend(*axes[0][-1].get_legend_handles_labels(), loc="outside lower center", ncol=3, fontsize=7)
    fig.suptitle(f"trajectory {traj}: solid actuator side, dashed joint side of the same set", fontsize=10)
    return fig


def above_no_loss(rec: Recording) -> float:
    """Share of frames whose terminal joint-side tension exceeds its actuator-side tension [-]."""
    n = rec.n_modules
    return float(np.mean(rec.terminal > rec.actuator[:, n - 1]))


def actuator_vs_terminal_figure(rec: Recording):
    """Terminal joint-side against actuator-side tension of the terminal set, with the no-loss line."""
    plt = pyplot()
    n = rec.n_modules
    fig, ax = plt.subplots(figsize=(4.6, 4.2), layout="constrained")
    for i in range(rec.n_tendons):
        ax.plot(rec.actuator[:, n - 1, i], rec.terminal[:, i], ".", ms=1.5, alpha=0.4, label=f"tendon {i + 1}")
    hi = float(np.nanmax(rec.actuator[:, n - 1]))
    ax.plot([0, hi], [0, hi], "k--", lw=1, label="joint side = actuator side")
    ax.set_xlabel(f"actuator side T[1,{n}] [N]")
    ax.set_ylabel(f"terminal joint side T[{n},{n}] [N]")
    ax.legend(fontsize=7, markerscale=6)
    ax.grid(alpha=0.3)
    return fig


def actuator_vs_terminal_caption(rec: Recording) -> str:
    """The caption of :func:`actuator_vs_terminal_figure`, with the share of frames above the line measured."""
    return (
        "Terminal joint side against actuator side for the terminal set. Below the dashed line the joint side "
        "carries less than the actuator side: friction at the guides opposes a tendon being pulled (loading). "
        f"{above_no_loss(rec):.0%} of the frames lie above it: while a tendon is released, friction reverses and "
        "holds tension at the joint side (the hysteresis the nonsmooth models carry as memory)."
    )


def add_recordings(page: HtmlPage, recordings: Sequence[Recording], heading: str = "The data") -> None:
    """Append the recordings' table, their wrap coverage, and per protocol a trace and the actuator/terminal plot."""
    page.heading(heading)
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
    page.heading("Wrap coverage per guide", level=3)
    page.figure(
        wrap_coverage_figure(recordings), "Backbone wrap alpha_k (paper Eq. (3)) seen by each guide, per protocol."
    )
    for rec in recordings:
        page.heading(f"Tension traces: {rec.protocol}", level=3)
        page.figure(
            tension_trace_figure(rec),
            "Each panel is one set: its actuator-side tensions (solid) and its own joint-side tensions (dashed), "
            "so the gap between a solid and a dashed line of one colour is that set's transmission loss.",
        )
        page.figure(actuator_vs_terminal_figure(rec), actuator_vs_terminal_caption(rec))


def summary_page(recordings: Sequence[Recording], title: str = "tendon-id recording summary") -> HtmlPage:
    """A page with the recordings' table and their figures (:func:`add_recordings`)."""
    page = HtmlPage(title)
    add_recordings(page, recordings, heading="Recordings")
    return page
