"""A snake recording described for ``tendon-id info``: as JSON (:func:`summarise`) and as text.

The text is :func:`format_summary`'s.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tendon_id.data.schema import intermediate_joints

__all__ = ["format_summary", "summarise"]


def _range(a: np.ndarray) -> dict[str, float]:
    return {"min": float(np.min(a)), "max": float(np.max(a))}


def summarise(recording: Any) -> dict[str, Any]:
    """The description returned by :meth:`tendon_id.data.Recording.describe`.

    Parameters
    ----------
    recording : Recording
        A validated recording (read through its public attributes only, so this module does
        not import :mod:`tendon_id.data.recording`).

    Returns
    -------
    dict
        See :meth:`tendon_id.data.Recording.describe`.
    """
    rec = recording
    starts = np.flatnonzero(rec.trajectory_starts)
    ends = np.append(starts[1:], rec.n_frames) - 1
    lengths = ends - starts + 1
    t = rec.time
    duration = float(np.sum(t[ends] - t[starts]) + len(starts) * rec.dt)
    ids = rec.frame["trajectory"].to_numpy()
    meta = rec.meta
    angles = rec.angles
    joints = intermediate_joints(rec.frame.columns, rec.n_modules, rec.n_tendons)
    return {
        "n_modules": rec.n_modules,
        "n_frames": rec.n_frames,
        "n_trajectories": int(len(starts)),
        "trajectories": {str(ids[s]): int(n) for s, n in zip(starts, lengths)},
        "duration_s": duration,
        "protocol": rec.protocol,
        "sample_rate_hz": rec.sample_rate_hz,
        "ranges": {
            "angle_rad": _range(angles),
            "angle_deg": _range(np.degrees(angles)),
            "actuator_n": _range(rec.actuator),
            "terminal_n": _range(rec.terminal),
        },
        "truth": {
            "terminal": True,
            "intermediate": len(joints) == rec.n_modules - 1,
            "intermediate_joints": joints,
        },
        "effects": list(meta["effects"]),
        "recipe": meta["recipe"],
        "seed": meta["seed"],
        "source": rec.source,
    }


def format_summary(s: dict, name: str) -> str:
    """Render :meth:`tendon_id.data.Recording.describe` as a few aligned lines."""
    r = s.get("ranges", {})
    truth = s.get("truth", {})
    inter = truth.get("intermediate_joints") or []
    lines = [
        f"recording     {name}",
        f"modules       {s['n_modules']}",
        f"frames        {s['n_frames']}  ({s.get('duration_s', 0):.1f} s at {s.get('sample_rate_hz', 0):g} Hz)",
        f"trajectories  {s['n_trajectories']}",
        f"protocol      {s.get('protocol') or '-'}",
        f"recipe        {s.get('recipe') or '-'}   seed {s.get('seed') if s.get('seed') is not None else '-'}",
        f"effects       {', '.join(s.get('effects') or []) or 'none'}",
    ]
    for key, label, unit in (
        ("angle_deg", "angles", "deg"),
        ("actuator_n", "actuator", "N"),
        ("terminal_n", "terminal", "N"),
    ):
        if key in r:
            lo, hi = r[key]["min"], r[key]["max"]
            lines.append(f"{label:<13} {lo:9.2f} .. {hi:9.2f} {unit}")
    lines.append(
        "truth         terminal joint side: yes; intermediate joint sides: "
        + (f"yes (joints {inter[0]}..{inter[-1]})" if truth.get("intermediate") and inter else "no")
    )
    return "\n".join(lines)
