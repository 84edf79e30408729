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
from tendon_id.identifiability import analyse
from tendon_id.report.comparison import add_comparison
from tendon_id.report.identifiability import write_report
from tendon_id.report.summary import summary_page

#: How the demo's models are labelled on its page.
LABELS = {"capstan-nonsmooth": "capstan-nonsmooth", "pg-chtc": "PG-CHTC (fast)", "pg-chtc-ns": "PG-CHTC-NS (fast)"}
#: Frames per protocol shown in the recording summary.
DEMO_FRAMES = {"terminal-only": 5000, "posterior-3": 5000, "posterior-6": 3000, "planned-paths": 5000}


def write_identifiability(rec, path: Path, *, progress: bool | None = None) -> Path:
    """The identifiability report (and its JSON beside it) of one recording."""
    result = analyse(rec, progress=progress)
    return write_report(result, path, path.with_suffix(".json"))


def write_diagnosis(base, split, path: Path, *, progress: bool | None = None) -> Path:
    """The gap diagnosis of the calibrated baseline (and its JSON beside it).

    Trained on the posterior-protocol trajectories of the training split (the terminal-only
    pool would make it slow) and scored on the held-out test trajectories of every protocol.
    """
    from tendon_id.diagnosis import diagnose
    from tendon_id.report.diagnosis import write_report

    posterior = [t for t in split.train.trajectories if t.startswith("posterior")]
    train = split.train.select(posterior)
    result = diagnose(base, train, [split.test[p] for p in TEST_PROTOCOLS], progress=progress)
    return write_report(result, path, path.with_suffix(".json"))


def write_closed_loop(recipe: str, fitted: dict, path: Path, *, progress: bool | None = None) -> Path:
    """The posterior-3 step test (one seed) with the demo's models (by zoo name) and the oracle in the loop."""
    from tendon_id.benchmarks.table3 import closed_loop_tests
    from tendon_id.report.closed_loop import write_table3_page

    t0 = time.perf_counter()
    models = {"oracle": None, **fitted}
    result = closed_loop_tests(recipe, models, [0], ["posterior-3"], progress=progress)
    result.update(recipe=recipe, preset="fast", seconds=time.perf_counter() - t0, fit_seconds=0.0)
    return write_table3_page(result, path, made_by="tendon-id demo (one seed; the full table: benchmark table3)")


def run_demo(
    out: str | os.PathLike = "out",
    *,
    recipe: str = DEFAULT_RECIPE,
    frames: int | None = None,
    models: bool = True,
    progress: bool | None = None,
) -> Path:
    """Build the demo and write ``out/summary.html``.

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
    recs = [load(recipe, protocol=p, frames=frames or n, progress=progress) for p, n in DEMO_FRAMES.items()]
    page = summary_page(recs, title=f"tendon-id demo: {recs[0].meta.get('recipe', recipe)}")
    if models:
        split = paper_split(recipe, 0, progress=progress)
        fitted = {  # by zoo name
            "capstan-nonsmooth": zoo.make("capstan-nonsmooth").fit(split.calibration),
            "pg-chtc": zoo.make("pg-chtc", preset="fast", progress=progress).fit(split.calibration),
            "pg-chtc-ns": zoo.make("pg-chtc-ns", preset="fast", progress=progress).fit(split.calibration),
        }
        add_comparison(
            page,
            {p: split.test[p] for p in TEST_PROTOCOLS},
            {LABELS[name]: model for name, model in fitted.items()},
            "Capstan-nonsmooth against PG-CHTC and PG-CHTC-NS on held-out trajectories (paper Table II split)",
        )
        diag = write_diagnosis(fitted["capstan-nonsmooth"], split, out / "diagnosis.html", progress=progress)
        page.heading("Sim-to-real gap")
        page.link(
            diag.name,
            diag.name,
            before="Where capstan-nonsmooth disagrees with the recipe's truth, which unmodelled effect explains it, "
            "and how far the gap shrinks once it is added: ",
            after=".",
        )
        terminal_only = next(r for r in recs if r.protocol == "terminal-only")
        ident = write_identifiability(terminal_only, out / "identifiability.html", progress=progress)
        page.heading("Identifiability")
        page.link(
            ident.name,
            ident.name,
            before="What the terminal-only data can and cannot tell (tied against per-guide laws, "
            "the intermediate-tension ambiguity band, which joint to instrument next): ",
            after=".",
        )
        loop = write_closed_loop(recipe, fitted, out / "closed_loop.html", progress=progress)
        page.heading("Closed loop")
        page.link(
            loop.name,
            loop.name,
            before="The estimators inside a 10 Hz hybrid controller on the simulated robot, a 5 degree step of "
            "joints 10-12 and back (the paper's Fig. 6 and Table III, one seed; the full table is "
            "tendon-id benchmark table3): ",
            after=".",
        )
    page.paragraph(f"Built in {time.perf_counter() - t0:.0f} s.", cls="note")
    return page.write(out / "summary.html")
