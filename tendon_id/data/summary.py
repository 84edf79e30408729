"""A JSON-serialisable summary of a recording, for ``tendon-id info``."""

from __future__ import annotations

from typing import Any

import numpy as np

from tendon_id.data.schema import intermediate_joints

__all__ = ["summarise"]


def _range(a: np.ndarray) -> dict[str, float]:
    return {"min": float(np.min(a)), "max": float(np.max(a))}


def summarise(recording: Any) -> dict[str, Any]:
    """The summary returned by :meth:`tendon_id.data.Recording.summary`.

    Parameters
    ----------
    recording : Recording
        A validated recording (read through its public attributes only, so this module does
        not import :mod:`tendon_id.data.recording`).

    Returns
    -------
    dict
        See :meth:`tendon_id.data.Recording.summary`.
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
    joints = intermediate_joints(rec.frame.columns, rec.n_modules)
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
