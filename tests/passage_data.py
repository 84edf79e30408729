"""Synthetic single-passage recordings for the tests, from the model's own physics."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from tendon_id.data.passage import PassageRecording
from tendon_id.zoo.passage import PassageCapstan, PassageInputs

BENCH = Path(__file__).resolve().parents[2] / "shared" / "data" / "real" / "mis-tool-characterization"
TRUE = {"gain": 0.95, "phi": 0.3, "offset": 0.2}


def tendon_passage(seed: int, n: int = 1500, dt: float = 0.01, blocks=("stick_slip",)) -> PassageRecording:
    """A single tendon over a capstan, with stick/slip: its output from the model's own physics, plus noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    position = 0.6 * np.sin(2 * np.pi * 0.3 * t + seed) + 0.1 * np.sin(2 * np.pi * 0.07 * t)
    tension_in = 30.0 + 12.0 * position + 3.0 * np.sin(2 * np.pi * 1.1 * t)
    frame = pd.DataFrame({"trajectory": f"run{seed}", "t": t, "input": tension_in, "output": 1.0, "position": position})
    rec = PassageRecording(frame, {"quantity": "tension", "wrap_angle": None})
    truth = PassageCapstan(blocks=blocks).reading(PassageInputs.from_recordings(rec), TRUE)
    return PassageRecording(frame.assign(output=truth + 0.05 * rng.standard_normal(n)), rec.meta)
