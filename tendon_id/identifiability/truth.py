"""What the data is and, for simulated data, what the simulator's truth is (:doc:`/guide/identifiability`).

A simulated recording's metadata carries the recipe's truth friction law
(``meta["friction_truth"]``, written by :func:`tendon_id.sim.simulate`: the per-tendon
affine-cosine law ``mu_i(alpha) = A_i cos(alpha) + B_i``, paper Eq. (4), the same at every guide)
and the effects the simulator added to it (``meta["effects"]``).  The study never fits to either;
the report sets them beside the fitted numbers so that a reader of simulated data sees how far
the finding is from the truth.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tendon_id.data import Recording


def data_name(recs: Sequence[Recording]) -> str:
    """A short name for the data: the recipe and protocol of simulated data, else the file name.

    Parameters
    ----------
    recs : sequence of Recording

    Returns
    -------
    str
        For example ``"snake12-paper, terminal-only"``, ``"bench.parquet"``, or
        ``"unnamed terminal-only data"`` for an unnamed recording; ``" (+ 2 more)"`` is
        appended when several recordings with different names are analysed together.
    """
    names = []
    for r in recs:
        recipe = r.meta.get("recipe")
        if recipe:
            name = f"{recipe}, {r.protocol}" if r.protocol else str(recipe)
        elif r.source:
            name = Path(r.source).name
        else:
            name = f"unnamed {r.protocol} data" if r.protocol else "unnamed data"
        if name not in names:
            names.append(name)
    return names[0] + (f" (+ {len(names) - 1} more)" if len(names) > 1 else "")


def truth_law(recs: Sequence[Recording]) -> dict | None:
    """The simulator's truth friction law and effects, where every recording carries the same one.

    Parameters
    ----------
    recs : sequence of Recording

    Returns
    -------
    dict or None
        ``recipe``; ``A``, ``B`` and ``mu0 = A + B`` per tendon [-] (the same at every guide);
        ``feasible``: whether the law meets the calibration's constraint ``B >= |A|`` (``mu >= 0``
        on ``[0, pi]``), so that a fit could reach it at all; ``effects``: the simulator's
        effects on top of the law.  None for data without a truth law (real data), or
        recordings whose truths differ.
    """
    laws = [r.meta.get("friction_truth") for r in recs]
    if not laws or any(not law for law in laws) or any(law != laws[0] for law in laws):
        return None
    A = np.asarray(laws[0]["A"], dtype=float)
    B = np.asarray(laws[0]["B"], dtype=float)
    effects = list(recs[0].meta.get("effects") or [])
    return {
        "recipe": recs[0].meta.get("recipe"),
        "A": [float(a) for a in A],
        "B": [float(b) for b in B],
        "mu0": [float(m) for m in A + B],
        "feasible": bool(np.all(B >= np.abs(A))),
        "effects": effects,
        "effect_params": dict(recs[0].meta.get("effect_params") or {}),
    }
