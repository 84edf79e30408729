"""``tendon-id demo``: the main job on the embedded default recipe, in a few minutes on a laptop CPU."""

from __future__ import annotations

import os
from pathlib import Path

from tendon_id.datasets import DEFAULT_RECIPE, load
from tendon_id.report.summary import write_summary

#: Frames per protocol in the demo: enough to see every effect, small enough to be quick.
DEMO_FRAMES = {"terminal-only": 5000, "posterior-3": 5000, "posterior-6": 3000, "planned-paths": 5000}


def run_demo(out: str | os.PathLike = "out", *, recipe: str = DEFAULT_RECIPE, frames: int | None = None) -> Path:
    """Build the demo protocols of ``recipe`` and write ``out/summary.html``.

    Parameters
    ----------
    out : path
        Output folder.
    recipe : str
        Recipe name or file.
    frames : int, optional
        Frames per protocol instead of :data:`DEMO_FRAMES`.

    Returns
    -------
    Path
        The summary page.
    """
    out = Path(out)
    recs = [load(recipe, protocol=p, frames=frames or n) for p, n in DEMO_FRAMES.items()]
    return write_summary(recs, out / "summary.html", title=f"tendon-id demo: {recs[0].meta.get('recipe', recipe)}")
