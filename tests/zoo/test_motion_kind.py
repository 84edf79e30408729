"""The kind of motion of a trajectory, read from its joint angles: the simulator's protocols, noise, edge cases."""

import numpy as np
import pytest

from tendon_id.data import Recording
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.sim import simulate
from tendon_id.zoo.motion_kind import (
    KINDS,
    RULES,
    MotionKindRules,
    frame_kinds,
    motion_kind,
    split_by_kind,
    trajectory_kinds,
)

DEG = np.pi / 180.0
EXPECTED = {
    "posterior-3": "steps",
    "posterior-6": "steps",
    "planned-paths": "paths",
    "terminal-only": "scans",
    "single-passage": "scans",
}


@pytest.fixture(scope="module")
def recipe():
    return load_recipe("snake12-paper")


@pytest.mark.parametrize("protocol", list(EXPECTED))
@pytest.mark.parametrize("noise_deg", [0.0, 0.2])
def test_each_protocol_reads_as_its_kind_from_the_angles_alone(recipe, protocol, noise_deg):
    """Every trajectory of two seeds, also under angle noise well above the encoders' 0.09 deg step."""
    rng = np.random.default_rng(0)
    for seed in (0, 1):
        rec = simulate(recipe, protocol, frames=1500, seed=seed).recording
        for tid in rec.trajectories:
            angles = rec.select([tid]).angles
            angles = angles + rng.normal(0.0, noise_deg * DEG, angles.shape)
            assert motion_kind(angles, rec.dt) == EXPECTED[protocol], (protocol, seed, tid)


def test_the_protocol_label_is_reported_beside_but_not_used(recipe):
    steps = simulate(recipe, "posterior-3", frames=600, seed=0).recording
    paths = simulate(recipe, "planned-paths", frames=630, seed=0).recording
    pooled = Recording.concat([steps, paths])
    assert pooled.protocol is None  # stacking drops the label: the kinds must come from the angles
    kinds = trajectory_kinds(pooled)
    assert [k.kind for k in kinds] == ["steps"] * len(steps.trajectories) + ["paths"] * len(paths.trajectories)
    assert all(k.protocol is None for k in kinds)
    assert {k.protocol for k in trajectory_kinds([steps, paths])} == {"posterior-3", "planned-paths"}
    # frame order: the recordings stacked as given
    fk = frame_kinds([steps, paths])
    assert fk.shape == (steps.n_frames + paths.n_frames,)
    assert set(fk[: steps.n_frames]) == {"steps"} and set(fk[steps.n_frames :]) == {"paths"}
    assert kinds[-1].stop == pooled.n_frames and kinds[0].start == 0


def test_split_by_kind_keeps_each_input_apart(recipe):
    steps = simulate(recipe, "posterior-3", frames=600, seed=0).recording
    paths = simulate(recipe, "planned-paths", frames=630, seed=0).recording
    scans = simulate(recipe, "terminal-only", frames=1000, seed=0).recording
    split = split_by_kind([paths, Recording.concat([steps, scans])])
    assert list(split) == [k for k in KINDS]  # in KINDS order
    assert [r.trajectories for r in split["paths"]] == [paths.trajectories]
    assert [r.trajectories for r in split["steps"]] == [steps.trajectories]
    assert [r.trajectories for r in split["scans"]] == [scans.trajectories]


def test_edge_cases():
    held = np.zeros((50, 12, 2))
    assert motion_kind(held, 0.1) == "steps"  # all hold
    assert motion_kind(held[:1], 0.1) == "steps"  # one frame: nothing can move
    sweep = held.copy()
    sweep[:, -1, 0] = 0.3 * np.sin(np.linspace(0, 4 * np.pi, 50))  # one joint with reversals
    assert motion_kind(sweep, 0.1) == "scans"
    every = held + np.linspace(0, 0.3, 50)[:, None, None]  # all joints together
    assert motion_kind(every, 0.1) == "paths"
    with pytest.raises(ConfigError, match=r"shape \(T, N, 2\)"):
        motion_kind(np.zeros((5, 3)), 0.1)
    with pytest.raises(ConfigError, match="sample period"):
        motion_kind(held, 0.0)


def test_the_rules_round_trip_and_refuse_what_cannot_work():
    assert MotionKindRules.from_dict(RULES.to_dict()) == RULES
    assert MotionKindRules.from_dict(None) == RULES
    assert MotionKindRules.from_dict({"held_share": 0.7}).held_share == 0.7
    with pytest.raises(ConfigError, match="held_share"):
        MotionKindRules(held_share=1.5)
    with pytest.raises(ConfigError):
        MotionKindRules.from_dict({"speed": 1.0})
