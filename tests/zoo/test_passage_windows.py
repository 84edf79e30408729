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


def whole_derivations(inputs: PassageInputs, band: float) -> dict:
    """The derived arrays computed on whole-length arrays, as before they were sliced (the reference)."""
    from friction_models import play_operator
    from tendon_id.zoo.passage.inputs import SPEED_WINDOW_S

    n = inputs.n_frames
    first = np.maximum.accumulate(np.where(inputs.reset, np.arange(n), 0))
    x = inputs.travel()
    back = np.maximum(np.arange(n) - max(int(round(SPEED_WINDOW_S / inputs.dt)), 1), first)
    moved = x - x[back]
    sigma = np.where(np.abs(moved) > band, np.sign(moved), 0.0).astype(np.int8)
    moving = np.flatnonzero(sigma != 0)
    starts = np.flatnonzero(inputs.reset)
    at = np.searchsorted(moving, starts)
    idx = moving[np.minimum(at, max(moving.size - 1, 0))] if moving.size else starts
    first_sigma = np.where((at < moving.size) & (first[idx] == starts), sigma[idx], 1).astype(np.int8)
    follower = play_operator(x, band, inputs.reset).log_out
    step = np.abs(np.diff(x))
    return {
        "band": 2.0 * float(np.median(step[step > 0])),
        "first_frame": first,
        "since_start": (np.arange(n) - first) * inputs.dt,
        "slip_state": sigma,
        "first_motion": first_sigma[np.searchsorted(starts, first, side="left")],
        "direction": np.where(x - follower >= 0, 1, -1).astype(np.int8),
        "speed": moved / (np.maximum(np.arange(n) - back, 1) * inputs.dt),
    }


@pytest.mark.parametrize("slice_frames", [1, 37, 1 << 18])
def test_derived_arrays_in_slices_are_the_whole_computation(monkeypatch, slice_frames):
    from tendon_id.family import inputs as family_inputs
    from tendon_id.zoo.passage import blocks as passage_blocks

    monkeypatch.setattr(family_inputs, "SLICE_FRAMES", slice_frames)  # every slice loop reads it (frame_slices)
    recs = [tendon_passage(s, n=300) for s in range(3)]
    still = recs[0].frame.assign(trajectory="still", input=1.0, position=0.0)  # never moves: first motion +1
    recs.append(PassageRecording(still, recs[0].meta))
    inputs = PassageInputs.from_recordings(recs)
    band = 0.5 * float(np.std(np.diff(inputs.travel())))
    want = whole_derivations(inputs, band)
    got = {
        "first_frame": inputs.first_frame,
        "since_start": inputs.since_start,
        "slip_state": inputs.slip_state(band),
        "first_motion": inputs.first_motion(band),
        "direction": inputs.direction(band),
        "speed": inputs.speed(),
        "band": passage_blocks.scale_band(inputs),
    }
    a, b = 250, 700  # a window counts from the whole's frames
    np.testing.assert_array_equal(inputs.window(a, b).since_start, want["since_start"][a:b])
    assert not got["slip_state"][-300:].any() and np.all(got["first_motion"][-300:] == 1)  # the still one
    assert got["first_frame"].dtype == np.int32  # an index kept per frame: four bytes where they do
    for key, value in want.items():
        assert np.asarray(got[key]).dtype == np.asarray(value).dtype or key == "first_frame", key
        np.testing.assert_array_equal(got[key], value, err_msg=key)


@pytest.mark.parametrize("slice_frames", [1, 37, 1 << 18])
def test_strata_and_scales_in_slices_are_the_whole_computation(monkeypatch, slice_frames):
    """The diagnosis's reversal stratum and the fit's data scales, sliced and without copies, are the former bits."""
    from friction_models import play_operator
    from tendon_id.family import inputs as family_inputs
    from tendon_id.zoo.passage.diagnosis import REVERSAL_SHARE, passage_strata

    monkeypatch.setattr(family_inputs, "SLICE_FRAMES", slice_frames)
    inputs = PassageInputs.from_recordings([tendon_passage(s, n=300) for s in range(3)])
    x = inputs.travel()
    stuck = play_operator(x, REVERSAL_SHARE * float(np.ptp(x)), inputs.reset).sigma == 0
    strata = {name: mask for name, _, mask in passage_strata(inputs)}
    np.testing.assert_array_equal(strata["near reversals"], stuck)
    speed = np.abs(inputs.speed(keep=False))
    edges = np.quantile(speed, [0.25, 0.5])
    assert any(name.startswith("input speed Q1") for name in strata)
    np.testing.assert_array_equal(
        next(m for n, m in strata.items() if n.startswith("input speed Q2")), (speed >= edges[0]) & (speed < edges[1])
    )
    assert "speed" not in inputs.cache  # read once, not kept
    scales = data_scales(inputs)
    assert scales["speed"] == float(np.quantile(speed, 0.95))
    assert scales["signal"] == float(np.max(np.abs(inputs.output)))
    assert scales["input"] == float(np.max(np.abs(inputs.input)))
    inputs.speed()  # kept: the magnitude is then a copy, and the kept speed is left as it was
    kept = inputs.speed().copy()
    assert inputs.speed_magnitude() is not inputs.cache["speed"]
    np.testing.assert_array_equal(inputs.speed(), kept)


@pytest.mark.parametrize("base_blocks", [(), ("stick_slip",)], ids=["base", "stick_slip"])
def test_signatures_in_windows_are_the_whole_readings_difference(monkeypatch, base_blocks):
    """The diagnosis's signature columns, made window by window, are the whole readings' difference, bit for bit."""
    from tendon_id.zoo.passage import model as passage_model
    from tendon_id.zoo.passage.blocks import PASSAGE_BLOCKS
    from tendon_id.zoo.passage.diagnosis import signatures

    inputs = PassageInputs.from_recordings([tendon_passage(s, n=700) for s in range(3)])
    fitted = PassageCapstan(blocks=base_blocks)
    fitted.theta_ = theta_for(fitted, inputs)
    names = ["velocity_friction", "clock_skew", "smooth_edge" if base_blocks else "stick_slip"]
    blocks = {n: PASSAGE_BLOCKS[n]() for n in names}
    scale = data_scales(inputs)
    want = np.stack(
        [
            fitted.with_blocks(b).reading(
                inputs, {**fitted.theta_, **{f"{n}:{p}": v for p, v in b.probe(scale).items()}}
            )
            - fitted.reading(inputs, fitted.theta_)
            for n, b in blocks.items()
        ],
        axis=-1,
    )[:, None]
    monkeypatch.setattr(passage_model, "WINDOW_FRAMES", 37)  # windows inside trajectories
    got = signatures(fitted, inputs, blocks)
    assert got.labels == names
    np.testing.assert_array_equal(got.columns, want)
    assert np.abs(want).max() > 0  # the probes move the reading
