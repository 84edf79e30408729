"""Model comparison figures and tables: estimates against truth at the terminal and intermediate joints."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from tendon_id.data import Recording
from tendon_id.report.html import HtmlPage, pyplot
from tendon_id.zoo.guard import guard_message


def estimates_figure(
    rec: Recording, predictions: Mapping[str, np.ndarray], joints: tuple[int, ...] = (4, 8, 12), tendon: int = 1
):
    """Joint-side estimates of several models against truth for one trajectory.

    Parameters
    ----------
    rec : Recording
        One trajectory, with intermediate truth.
    predictions : mapping of model name to ndarray (T, N, 3)
    joints : tuple of int
        1-based joints to show (the last is the terminal joint).
    tendon : int
        1-based tendon.
    """
    plt = pyplot()

    truth = rec.joint_truth
    fig, axes = plt.subplots(1, len(joints), figsize=(4.2 * len(joints), 3.2), sharey=False)
    for ax, j in zip(np.atleast_1d(axes), joints):
        ax.plot(rec.time, rec.actuator[:, j - 1, tendon - 1], color="0.6", lw=1, label="actuator side")
        if truth is not None:
            ax.plot(rec.time, truth[:, j - 1, tendon - 1], color="k", lw=1.6, label="truth")
        for k, (name, pred) in enumerate(predictions.items()):
            ax.plot(rec.time, pred[:, j - 1, tendon - 1], lw=1.1, color=f"C{k}", label=name)
        ax.set_title(f"joint {j}" + (" (terminal)" if j == rec.n_modules else ""))
        ax.set_xlabel("t [s]")
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[0].set_ylabel(f"tendon {tendon} tension [N]")
    np.atleast_1d(axes)[-1].legend(fontsize=7)
    return fig


def per_joint_rmse_figure(scores: Mapping[str, dict]):
    """RMSE at every joint for several models (needs simulator truth)."""
    plt = pyplot()

    fig, ax = plt.subplots(figsize=(7, 3.2))
    for k, (name, s) in enumerate(scores.items()):
        if s.get("joints"):
            rmse = [m["rmse"] for m in s["joints"]["per_joint"]]
            ax.plot(np.arange(1, len(rmse) + 1), rmse, "o-", color=f"C{k}", label=name)
    ax.set_xlabel("joint j")
    ax.set_ylabel("RMSE of T[j, j] [N]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def add_guards(page: HtmlPage, models: Mapping[str, object]) -> None:
    """One line per learned cascade: its validation RMSE against its calibrated prior's, a warning when worse."""
    for name, model in models.items():
        guard = getattr(model, "guard_", None)
        if not guard:
            continue
        lines = guard_message(name, guard).split("\n")
        page.paragraph(lines[0] + ".", cls="note")
        for line in lines[1:]:
            page.paragraph(line, cls="warning")


def add_comparison(page: HtmlPage, test: dict[str, Recording], models: Mapping[str, object], heading: str) -> dict:
    """Append a model-comparison section (table per protocol, per-joint RMSE, traces); returns the scores."""
    page.heading(heading)
    rows, all_scores = [], {}
    for protocol, rec in test.items():
        for name, model in models.items():
            s = model.score(rec)
            all_scores.setdefault(protocol, {})[name] = s
            j = s["joints"]["overall"] if s.get("joints") and s["joints"]["overall"] else None
            rows.append([protocol, name, s["terminal"]["rmse"], s["terminal"]["r2"], j["rmse"] if j else "-"])
    page.table(["protocol", "model", "terminal RMSE [N]", "terminal R2", "intermediate joints RMSE [N]"], rows)
    add_guards(page, models)
    first = next(iter(test))
    page.figure(per_joint_rmse_figure(all_scores[first]), f"RMSE at every joint on held-out {first} trajectories.")
    rec = test[first].select([test[first].trajectories[0]])
    page.figure(
        estimates_figure(rec, {n: m.predict(rec) for n, m in models.items()}),
        "Joint-side estimates against simulator truth on a held-out trajectory: "
        "intermediate joints 4 and 8 and the terminal joint.",
    )
    return all_scores
