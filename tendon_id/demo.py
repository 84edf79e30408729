"""``tendon-id demo``: the main job on the embedded default recipe, in a few minutes on a laptop CPU.

It simulates the default recipe's protocols, then trains PG-CHTC and PG-CHTC-NS (fast preset)
and calibrates the capstan-nonsmooth baseline on the paper's training split, and writes one
self-contained page comparing them on held-out trajectories, at the terminal joint and at
the intermediate joints the paper could not measure.  Linked pages: the gap diagnosis, the
identifiability report, and the estimators in closed loop (a step like the paper's Fig. 6).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from tendon_id import zoo
from tendon_id.benchmarks.splits import TEST_PROTOCOLS, paper_split
from tendon_id.datasets import DEFAULT_RECIPE, load
from tendon_id.progress import stage
from tendon_id.report.comparison import add_comparison
from tendon_id.report.html import HtmlPage
from tendon_id.report.summary import add_recordings
from tendon_id.report.truth import truth_sentence

#: How the demo's models are labelled on its page.
LABELS = {"capstan-nonsmooth": "capstan-nonsmooth", "pg-chtc": "PG-CHTC (fast)", "pg-chtc-ns": "PG-CHTC-NS (fast)"}
#: Frames per protocol shown in the recording summary.
DEMO_FRAMES = {"terminal-only": 5000, "posterior-3": 5000, "posterior-6": 3000, "planned-paths": 5000}


def write_identifiability(rec, path: Path, *, progress: bool | None = None):
    """The identifiability report (and its JSON beside it) of one recording; returns the page's path and the result."""
    # Imported here, as the diagnosis's are: looked up when called, never bound when this module loads.
    from tendon_id.identifiability import analyse
    from tendon_id.report.identifiability import write_report

    result = analyse(rec, progress=progress)
    return write_report(result, path, path.with_suffix(".json")), result


def write_diagnosis(base, split, path: Path, *, progress: bool | None = None):
    """The gap diagnosis of the calibrated baseline (and its JSON beside it); returns the page's path and the result.

    Trained on the posterior-protocol trajectories of the training split (the terminal-only
    pool would make it slow) and scored on the held-out test trajectories of every protocol.
    """
    from tendon_id.diagnosis import diagnose
    from tendon_id.report.diagnosis import write_report

    posterior = [t for t in split.train.trajectories if t.startswith("posterior")]
    train = split.train.select(posterior)
    result = diagnose(base, train, [split.test[p] for p in TEST_PROTOCOLS], progress=progress)
    return write_report(result, path, path.with_suffix(".json")), result


def write_closed_loop(
    recipe: str, fitted: dict, path: Path, *, open_loop: dict | None = None, progress: bool | None = None
) -> tuple[Path, str]:
    """The posterior-3 step test (one seed) with the demo's models (by zoo name) and the oracle in the loop.

    ``open_loop`` (zoo name to open-loop intermediate-joint RMSE [N]) lets the page compare the rankings.
    Returns the page's path and its first sentence.
    """
    from tendon_id.benchmarks.table3 import closed_loop_tests
    from tendon_id.report.closed_loop import write_table3_page
    from tendon_id.report.closed_loop_lead import lead_sentences

    t0 = time.perf_counter()
    models = {"oracle": None, **fitted}
    result = closed_loop_tests(recipe, models, [0], ["posterior-3"], progress=progress)
    result.update(recipe=recipe, preset="fast", seconds=time.perf_counter() - t0, fit_seconds=0.0)
    page = write_table3_page(
        result, path, made_by="tendon-id demo (one seed; the full table: benchmark table3)", open_loop=open_loop
    )
    return page, lead_sentences(result, open_loop)[0][0]


def run_demo(
    out: str | os.PathLike = "out",
    *,
    recipe: str = DEFAULT_RECIPE,
    frames: int | None = None,
    models: bool = True,
    progress: bool | None = None,
) -> Path:
    """Build the demo and write ``out/summary.html``.

    The page opens with the result (the models on held-out trajectories, beside the
    simulator's truth), then links the diagnosis, identifiability and closed-loop pages with
    what each found, and ends with the simulated data.

    Parameters
    ----------
    out : path
        Output folder.
    recipe : str
        Recipe name or file.
    frames : int, optional
        Frames per protocol in the summary instead of :data:`DEMO_FRAMES`.
    models : bool
        Also train PG-CHTC and PG-CHTC-NS and calibrate capstan-nonsmooth (the slow part, a few minutes), and
        write the gap diagnosis of capstan-nonsmooth and the identifiability report of the
        terminal-only data, linked from the page.
    progress : bool, optional
        Progress bars (default: on a terminal).

    Returns
    -------
    Path
        The page.
    """
    t0 = time.perf_counter()
    out = Path(out)
    with stage("simulate the recipe's protocols"):
        recs = [load(recipe, protocol=p, frames=frames or n, progress=progress) for p, n in DEMO_FRAMES.items()]
    name = recs[0].meta.get("recipe", recipe)
    page = HtmlPage(
        f"tendon-id demo: {name}",
        subtitle="Tendon-tension estimators on the default recipe's simulated 12-module snake robot.",
        made_by="tendon-id demo",
        contents=True,
    )
    if models:
        with stage("simulate the paper's split"):
            split = paper_split(recipe, 0, progress=progress)
        with stage("fit capstan-nonsmooth, pg-chtc and pg-chtc-ns"):
            fitted = {  # by zoo name
                "capstan-nonsmooth": zoo.make("capstan-nonsmooth").fit(split.calibration),
                "pg-chtc": zoo.make("pg-chtc", preset="fast", progress=progress).fit(split.calibration),
                "pg-chtc-ns": zoo.make("pg-chtc-ns", preset="fast", progress=progress).fit(split.calibration),
            }
        test = {p: split.test[p] for p in TEST_PROTOCOLS}
        with stage("compare the estimators"):
            scores = add_comparison(
                page,
                test,
                {LABELS[n]: model for n, model in fitted.items()},
                "Result: the estimators on held-out trajectories (paper Table II split)",
                train=split.calibration,
            )
        open_loop = add_result_lead(page, scores, recs[0].meta)
        base = fitted["capstan-nonsmooth"]
        with stage("diagnose capstan-nonsmooth"):
            diag, diag_result = write_diagnosis(base, split, out / "diagnosis.html", progress=progress)
        page.heading("Sim-to-real gap")
        page.link(
            diag.name,
            diag.name,
            before="Where capstan-nonsmooth disagrees with the recipe's truth, which unmodelled effect explains it, "
            f"and how far the gap shrinks once it is added. Its verdict: {diag_result.verdict.text}. ",
            after=".",
        )
        terminal_only = next(r for r in recs if r.protocol == "terminal-only")
        with stage("identifiability of the terminal-only data"):
            ident, ident_result = write_identifiability(terminal_only, out / "identifiability.html", progress=progress)
        page.heading("Identifiability")
        page.link(
            ident.name,
            ident.name,
            before="What the terminal-only data can and cannot tell (tied against per-guide laws, "
            "the intermediate-tension ambiguity band, which joint to instrument next). It opens: "
            f"{ident_result.to_dict()['summary'][0]['text']} ",
            after=".",
        )
        by_name = {name: open_loop[LABELS[name]] for name in fitted}
        with stage("closed loop"):
            loop, loop_finding = write_closed_loop(
                recipe, fitted, out / "closed_loop.html", open_loop=by_name, progress=progress
            )
        page.heading("Closed loop")
        page.link(
            loop.name,
            loop.name,
            before="The estimators inside a 10 Hz hybrid controller on the simulated robot, a 5 degree step of "
            "joints 10-12 and back (the paper's Fig. 6 and Table III, one seed; the full table is "
            f"tendon-id benchmark table3). {loop_finding} ",
            after=".",
        )
    else:
        sentence = truth_sentence(recs[0].meta)
        page.lead("The simulated recordings only (no model was trained: --no-models).", tone="verdict")
        if sentence:
            page.lead(sentence, tone="truth")
    with stage("writing the summary"):
        add_recordings(page, recs, heading="The simulated data")
        page.paragraph(f"Built in {time.perf_counter() - t0:.0f} s.", cls="note")
        return page.write(out / "summary.html")


def add_result_lead(page: HtmlPage, scores: dict, meta: dict) -> dict[str, float]:
    """The summary's first screen: which model estimates the intermediate joints best, against the truth.

    Returns each model's intermediate-joint RMSE averaged over the protocols [N], by label.
    """
    pooled: dict[str, list[float]] = {}
    for by in scores.values():
        for label, s in by.items():
            pooled.setdefault(label, []).append(s["joints"]["overall"]["rmse"])
    means = {label: sum(v) / len(v) for label, v in pooled.items()}
    ranked = sorted(means, key=means.get)
    best, rest = ranked[0], ranked[1:]
    page.lead(
        f"On held-out trajectories ({', '.join(scores)}), {best} estimates the unmeasured intermediate joint-side "
        f"tensions best: {means[best]:.1f} N RMSE on average over the protocols, against "
        + ", ".join(f"{means[r]:.1f} N for {r}" for r in rest)
        + ".",
        tone="verdict",
    )
    sentence = truth_sentence(meta)
    if sentence:
        page.lead(
            sentence + " No model here contains all of it; every error on this page is against that truth.",
            tone="truth",
        )
    page.lead(
        "How far to trust it: one training split and seed, and the fast training preset (the paper's preset trains "
        "longer: tendon-id benchmark table2 --preset paper). Read the sentences under the table where a number "
        "surprises.",
        tone="plain",
    )
    return means
