"""Model comparison: a table, RMSE per joint and traces against truth, a sentence wherever the numbers surprise."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from tendon_id.data import Recording
from tendon_id.geometry import backbone_wrap
from tendon_id.report.html import HtmlPage, pyplot
from tendon_id.zoo.guard import guard_message


def estimates_figure(
    rec: Recording, predictions: Mapping[str, np.ndarray], joints: tuple[int, ...] = (4, 8, 12), tendon: int = 1
):
    """Joint-side estimates of several models against truth for one trajectory.

    Each panel is one set ``j``: its own actuator-side tension ``T[1, j]``, its joint-side truth
    ``T[j, j]`` and the estimates of ``T[j, j]``, so a panel compares like with like.

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
    fig, axes = plt.subplots(1, len(joints), figsize=(4.2 * len(joints), 3.4), sharey=False, layout="constrained")
    for ax, j in zip(np.atleast_1d(axes), joints):
        ax.plot(rec.time, rec.actuator[:, j - 1, tendon - 1], color="0.6", lw=1, label=f"actuator side T[1,{j}]")
        if truth is not None:
            ax.plot(rec.time, truth[:, j - 1, tendon - 1], color="k", lw=1.6, label=f"truth T[{j},{j}]")
        for k, (name, pred) in enumerate(predictions.items()):
            ax.plot(rec.time, pred[:, j - 1, tendon - 1], lw=1.1, color=f"C{k}", label=name)
        ax.set_title(f"set {j}" + (" (terminal joint)" if j == rec.n_modules else ""), fontsize=10)
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


def _total_wrap(rec: Recording) -> np.ndarray:
    """The terminal set's total bend wrap per frame [rad] (paper Eq. (3) without the routing wrap, summed).

    The routing wrap adds the same to every frame of one robot, so it cancels in the comparison
    of a test's wraps with the training's; the metadata's (the simulator's truth) is not read.
    """
    return backbone_wrap(rec.angles, 0.0).sum(axis=-1)


def beyond_training(train: Recording, test: Recording) -> dict[str, float]:
    """Shares of ``test``'s frames outside what ``train`` saw [-].

    ``wrap``: the terminal set's total wrap exceeds the largest in training; ``tension``: an
    actuator-side tension of the terminal set is above the largest in training.
    """
    n = test.n_modules
    return {
        "wrap": float(np.mean(_total_wrap(test) > np.max(_total_wrap(train)))),
        "tension": float(np.mean(np.any(test.actuator[:, n - 1] > np.max(train.actuator[:, n - 1]), axis=-1))),
    }


def surprises(
    scores: Mapping[str, Mapping[str, dict]],
    test: Mapping[str, Recording],
    learned: set[str],
    train: Recording | None = None,
) -> list[str]:
    """Sentences for the numbers a reader would stop at: a negative R^2, a baseline beating a learned model.

    Parameters
    ----------
    scores : mapping protocol -> model name -> score (:meth:`Estimator.score`)
    test : mapping protocol -> held-out recording
    learned : set of str
        The names of the learned models (the ones a physics baseline is expected to lose to).
    train : Recording, optional
        The training data, to say whether a protocol asks the models to extrapolate.
    """
    out = []
    r2 = [(p, n, s["terminal"]["r2"]) for p, by in scores.items() for n, s in by.items()]
    negative = [x for x in r2 if x[2] < 0]
    if negative:
        worst = min(negative, key=lambda x: x[2])
        sd = float(np.mean(np.std(test[worst[0]].terminal, axis=0)))
        rmse = scores[worst[0]][worst[1]]["terminal"]["rmse"]
        out.append(
            f"R2 below 0 ({len(negative)} cells, down to {worst[2]:.2f} for {worst[1]} on {worst[0]}) means the model "
            "predicts the held-out terminal tension worse than that set's own mean would. R2 is 1 - RMSE^2 / variance "
            f"per tendon, and on {worst[0]} the terminal tension varies by only {sd:.1f} N (sd), so an error of "
            f"{rmse:.1f} N RMSE lands near 1 - ({rmse:.1f} / {sd:.1f})^2 = {1 - (rmse / sd) ** 2:.1f}. "
            "Read the RMSE, in newtons, first."
        )
    for protocol, by in scores.items():
        for base in sorted(set(by) - learned):
            for name in sorted(learned & set(by)):
                b, m = by[base]["terminal"]["rmse"], by[name]["terminal"]["rmse"]
                if b >= m:
                    continue
                text = (
                    f"On {protocol}, the physics baseline {base} beats {name} at the terminal joint "
                    f"({b:.1f} N against {m:.1f} N)."
                )
                if train is not None:
                    share = beyond_training(train, test[protocol])
                    if max(share.values()) > 0.01:
                        text += (
                            f" {share['wrap']:.0%} of its frames bend the chain further (total wrap) and "
                            f"{share['tension']:.0%} pull harder than any training frame: a learned ratio "
                            "extrapolates there, while a capstan law's exponential holds at any wrap and tension."
                        )
                    else:
                        text += (
                            " Its wraps and tensions stay inside the training range, so it is not extrapolation; "
                            "what else differs on this protocol is not measured here."
                        )
                out.append(text)
    return out


def add_comparison(
    page: HtmlPage,
    test: dict[str, Recording],
    models: Mapping[str, object],
    heading: str,
    train: Recording | None = None,
) -> dict:
    """Append a model-comparison section (table per protocol, sentences on surprises, per-joint RMSE, traces).

    Returns the scores, ``{protocol: {model: score}}``.
    """
    page.heading(heading)
    rows, all_scores = [], {}
    for protocol, rec in test.items():
        for name, model in models.items():
            s = model.score(rec)
            all_scores.setdefault(protocol, {})[name] = s
            j = s["joints"]["overall"] if s.get("joints") and s["joints"]["overall"] else None
            rows.append([protocol, name, s["terminal"]["rmse"], s["terminal"]["r2"], j["rmse"] if j else "-"])
    page.table(["protocol", "model", "terminal RMSE [N]", "terminal R2", "intermediate joints RMSE [N]"], rows)
    learned = {name for name, model in models.items() if hasattr(model, "guard_")}
    for sentence in surprises(all_scores, test, learned, train):
        page.paragraph(sentence)
    add_guards(page, models)
    first = next(iter(test))
    page.figure(per_joint_rmse_figure(all_scores[first]), f"RMSE at every joint on held-out {first} trajectories.")
    rec = test[first].select([test[first].trajectories[0]])
    n = rec.n_modules
    page.figure(
        estimates_figure(rec, {k: m.predict(rec) for k, m in models.items()}, joints=(n // 3, 2 * n // 3, n)),
        "Joint-side estimates against simulator truth on a held-out trajectory, one panel per set: each panel shows "
        "that set's own actuator-side tension, its joint-side truth and the estimates of it.",
    )
    return all_scores
