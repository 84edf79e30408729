"""A passage model read in windows of frames gives the numbers it gives read whole (issue 42's streaming)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from passage_data import tendon_passage

from tendon_id.data.passage import PassageRecording
from tendon_id.zoo.passage import PassageCapstan, PassageInputs
from tendon_id.zoo.passage.fitting import data_scales

BLOCKS = [
    (),
    ("stick_slip",),
    ("stick_slip", "smooth_edge"),
    ("cable_elasticity",),
    ("stick_slip", "velocity_friction", "load_coulomb", "position_torque"),
    ("stick_slip", "input_cells"),
    ("stick_slip", "clock_skew"),
]


def torque_passage(seed: int, n: int = 900) -> PassageRecording:
    """An antagonistic pair's torques and positions (any numbers will do: only the evaluation is compared)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 1e-3
    position = 0.8 * np.sin(2 * np.pi * 2.0 * t + seed) + 0.01 * rng.standard_normal(n)
    frame = pd.DataFrame(
        {
            "trajectory": f"pair{seed}",
            "t": t,
            "input": 0.2 * np.sin(2 * np.pi * 2.0 * t + seed + 0.3) + 0.01 * rng.standard_normal(n),
            "output": 0.1 * np.sin(2 * np.pi * 2.0 * t + seed),
            "position": position,
            "position_out": 0.9 * position,
        }
    )
    return PassageRecording(frame, {"quantity": "torque", "wrap_angle": None})


def theta_for(model: PassageCapstan, inputs: PassageInputs) -> dict:
    law = {"gain": 0.9, "phi": 0.3, "offset": 0.01, "pretension": 0.5, "sharing": 0.2, "input_offset": 0.002}
    s = data_scales(inputs)
    probes = {f"{b.effect}:{p}": v for b in model.block_objects for p, v in b.probe(s).items()}
    if "smooth_edge:width" in probes:
        probes["smooth_edge:width"] = 0.4
    return {**{k: law[k] for k in model.param_labels(inputs.quantity) if k in law}, **probes}


@pytest.mark.parametrize("blocks", BLOCKS, ids=lambda b: "+".join(b) or "base")
@pytest.mark.parametrize("direction", ["forward", "inverse"])
@pytest.mark.parametrize("quantity", ["tension", "torque"])
def test_windows_give_the_whole_reading_bit_for_bit(blocks, direction, quantity):
    recs = (
        [tendon_passage(s, n=700) for s in range(3)] if quantity == "tension" else [torque_passage(s) for s in range(3)]
    )
    inputs = PassageInputs.from_recordings(recs)
    model = PassageCapstan(blocks=blocks, direction=direction)
    theta = theta_for(model, inputs)
    whole = model.reading_at(PassageInputs.from_recordings(recs), theta)[0]
    # 37 frames a window: windows start inside trajectories and on their first frames
    parts = list(model.reading_windows(inputs, theta, frames=37))
    assert [(a, b) for a, b, _ in parts][:2] == ([(0, 37), (37, 74)] if model.streams else [(0, inputs.n_frames)])
    assert parts[-1][1] == inputs.n_frames
    np.testing.assert_array_equal(np.concatenate([y for _, _, y in parts]), whole)
    assert model.streams == ("clock_skew" not in blocks)


def test_a_window_refuses_a_derived_array_the_whole_inputs_lack():
    inputs = PassageInputs.from_recordings(tendon_passage(0, n=200))
    with pytest.raises(RuntimeError, match="was not computed on the whole inputs"):
        inputs.window(50, 100).speed()
    inputs.speed()
    np.testing.assert_array_equal(inputs.window(50, 100).speed(), inputs.speed()[50:100])
