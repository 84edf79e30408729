"""Motion protocols of the paper's Section IV-A (:doc:`/guide/simulator`).

Each protocol turns a random generator and its settings into a list of
trajectories of true joint angles, shape ``(frames, N, 2)`` [rad], sampled at
``dt``.  Every move is a minimum-jerk ramp whose peak joint speed stays below
``v_max_deg_s`` (8 deg/s by default, under the paper's 9 deg/s quasi-static
bound), and every pose keeps the backbone's total turning below ``pi``, which
keeps the serial chain from folding onto itself (collision-free).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from tendon_id.checks import check_keys
from tendon_id.errors import ConfigError
from tendon_id.sim.motion import PathBuilder

PROTOCOL_NAMES = ("terminal-only", "posterior-3", "posterior-6", "planned-paths", "single-passage")

#: The paper's frame counts (Section IV-A); single-passage is our unit-level rig.
PAPER_FRAMES = {
    "terminal-only": 50000,
    "posterior-3": 5000,
    "posterior-6": 3000,
    "planned-paths": 10000,
    "single-passage": 6000,
}

DEG = np.pi / 180.0


@dataclass(frozen=True)
class ProtocolSettings:
    """Settings of one protocol (angles in degrees as a recipe writes them, tensions in N).

    Parameters
    ----------
    frames : int
        Total frames. Defaults are the paper's counts.
    trajectory_frames : int
        Frames per trajectory (the unit of train/test splits).
    held_pose_deg : float
        Largest bend [deg] of a proximal joint held still (posterior protocols,
        terminal-only) or of the fixed first joint (single-passage).
    n_held_poses : int
        Distinct held proximal poses the trajectories cycle through.
    amplitudes_deg : tuple of float
        Step amplitudes [deg] (posterior protocols).
    range_deg : float
        Largest bend [deg] of a scanned (terminal-only, single-passage) or
        path-following (planned-paths) joint.
    hold_s : tuple of float
        Range of hold durations [s] after each step or waypoint.
    pretension_n : tuple of float
        Range of the per-trajectory pretension level [N].
    """

    frames: int = 1000
    trajectory_frames: int = 500
    held_pose_deg: float = 8.0
    n_held_poses: int = 4
    amplitudes_deg: tuple[float, ...] = (3.0,)
    range_deg: float = 20.0
    hold_s: tuple[float, float] = (2.0, 6.0)
    pretension_n: tuple[float, float] = (75.0, 160.0)

    def __post_init__(self) -> None:
        if self.frames < 1 or self.trajectory_frames < 2:
            raise ConfigError("protocol frames must be >= 1 and trajectory_frames >= 2")
        lo, hi = self.pretension_n
        if not 0 < lo <= hi:
            raise ConfigError(f"pretension_n must be a range 0 < lo <= hi in N, got {self.pretension_n}")
        object.__setattr__(self, "amplitudes_deg", tuple(float(a) for a in self.amplitudes_deg))
        object.__setattr__(self, "hold_s", tuple(float(a) for a in self.hold_s))
        object.__setattr__(self, "pretension_n", (float(lo), float(hi)))

    @classmethod
    def from_dict(cls, name: str, d: dict) -> ProtocolSettings:
        """Build from a recipe's ``[protocols.NAME]`` table; unknown keys are an error."""
        known = {f.name for f in fields(cls)}
        check_keys(d, known, what=f"setting of protocol {name!r}")
        return cls(**d)


def _total_turn_ok(pose: NDArray) -> bool:
    # A chain whose tangent turns by less than pi in all cannot fold back onto itself.
    return float(np.linalg.norm(pose, axis=-1).sum()) < np.pi


def held_pose(rng: np.random.Generator, n_modules: int, n_held: int, max_deg: float) -> NDArray:
    """A smooth proximal pose: bends of at most ``max_deg`` varying slowly along the chain."""
    for _ in range(100):
        k = np.arange(n_held)
        freq = rng.uniform(0.05, 0.25)
        phase = rng.uniform(0, 2 * np.pi, size=2)
        mag = rng.uniform(0.4, 1.0) * max_deg * DEG
        pose = np.zeros((n_modules, 2))
        pose[:n_held, 0] = mag * np.cos(2 * np.pi * freq * k + phase[0])
        pose[:n_held, 1] = mag * np.sin(2 * np.pi * freq * k + phase[1])
        if _total_turn_ok(pose):
            return pose
    raise ConfigError("held_pose_deg is too large: the chain would fold onto itself")


def _random_bends(rng: np.random.Generator, max_rad: float, n: int) -> NDArray:
    """``n`` bends uniform on the disk of radius ``max_rad`` [rad], shape (n, 2).

    One draw of (n, 2) uniforms: the same numbers, in the same order, as a radius and an angle
    drawn per bend, so the data of a seed do not depend on which way they are drawn.
    """
    u = rng.uniform(size=(n, 2))
    r, a = max_rad * np.sqrt(u[:, 0]), 2 * np.pi * u[:, 1]
    return np.stack([r * np.cos(a), r * np.sin(a)], axis=1)


@dataclass(frozen=True)
class MotionContext:
    """What a protocol needs besides its random generator."""

    n_modules: int
    settings: ProtocolSettings
    dt: float
    v_max: float
    traj_index: int
    held_poses: tuple[NDArray, ...]
    bending_axes: int = 2  # 1: a planar robot, whose steps are all towards x

    @property
    def held(self) -> NDArray:
        """The held pose of this trajectory (the protocol cycles through its poses)."""
        return self.held_poses[self.traj_index % len(self.held_poses)].copy()


def held_joint_count(name: str, n_modules: int) -> int:
    """How many proximal joints a protocol holds still."""
    return {
        "terminal-only": n_modules - 1,
        "posterior-3": max(n_modules - 3, 0),
        "posterior-6": max(n_modules - 6, 0),
        "planned-paths": 0,
        "single-passage": 1,
    }[name]


def _scan_last_joint(rng, ctx: MotionContext) -> NDArray:
    s = ctx.settings
    path = PathBuilder(ctx.held, ctx.v_max, ctx.dt)
    while path.frames < s.trajectory_frames:
        target = path.last
        target[-1] = _random_bends(rng, s.range_deg * DEG, 1)[0]
        path.move_to(target)
        if rng.uniform() < 0.3:
            path.hold(rng.uniform(*s.hold_s) / 3)
    return path.build(s.trajectory_frames)


def terminal_only(rng, ctx: MotionContext) -> NDArray:
    """Quasi-static scans of the terminal joint with reversals; proximal joints held at a few poses."""
    return _scan_last_joint(rng, ctx)


def single_passage(rng, ctx: MotionContext) -> NDArray:
    """The 2-module, one-guide rig: joint 1 held, joint 2 scanned with reversals."""
    if ctx.n_modules != 2:
        raise ConfigError("the single-passage protocol needs a 2-module rig (robot n_modules = 2)")
    return _scan_last_joint(rng, ctx)


def posterior(n_active: int) -> Callable:
    """Step-and-hold on the distal ``n_active`` modules; proximal joints held still."""

    def protocol(rng, ctx: MotionContext) -> NDArray:
        s, n = ctx.settings, ctx.n_modules
        first = max(n - n_active, 0)
        base = ctx.held
        path = PathBuilder(base, ctx.v_max, ctx.dt)
        path.hold(rng.uniform(*s.hold_s))
        while path.frames < s.trajectory_frames:
            target = base.copy()
            joints = rng.choice(np.arange(first, n), size=rng.integers(1, n - first + 1), replace=False)
            axis = rng.integers(0, ctx.bending_axes)
            target[joints, axis] = rng.choice(s.amplitudes_deg) * DEG * rng.choice([-1.0, 1.0])
            path.move_to(target)
            path.hold(rng.uniform(*s.hold_s))
            path.move_to(base)
            path.hold(rng.uniform(*s.hold_s) / 2)
        return path.build(s.trajectory_frames)

    protocol.__doc__ = f"Step-and-hold on the distal {n_active} modules; proximal joints held still."
    return protocol


def planned_paths(rng, ctx: MotionContext) -> NDArray:
    """Random smooth joint-space paths of all joints through collision-free waypoints."""
    s = ctx.settings
    path = PathBuilder(np.zeros((ctx.n_modules, 2)), ctx.v_max, ctx.dt)
    while path.frames < s.trajectory_frames:
        for _ in range(100):
            target = _random_bends(rng, s.range_deg * DEG, ctx.n_modules)
            if _total_turn_ok(target):
                break
        path.move_to(target)
        if rng.uniform() < 0.5:
            path.hold(rng.uniform(*s.hold_s) / 2)
    return path.build(s.trajectory_frames)


PROTOCOLS: dict[str, Callable] = {
    "terminal-only": terminal_only,
    "posterior-3": posterior(3),
    "posterior-6": posterior(6),
    "planned-paths": planned_paths,
    "single-passage": single_passage,
}
