"""The elastic tendon chain in the simulator (stick_slip.driver = "elastic"; docs/guide/simulator.rst)."""

import numpy as np
import pytest

from tendon_id.errors import ConfigError
from tendon_id.geometry import RobotGeometry
from tendon_id.sim import Effects
from tendon_id.sim.transmission import FrictionLaw, transmit
from tendon_id.sim.transmission_kernel import COMPILED
from tendon_id.sliding import segment_path_lengths

N, FRAMES, DT = 6, 600, 0.1


@pytest.fixture(scope="module")
def moving():
    """A 6-module robot bending both axes of every joint slowly (<= 4 deg), tensions cycling."""
    rng = np.random.default_rng(0)
    t = np.arange(FRAMES) * DT
    theta = np.zeros((FRAMES, N, 2))
    for m in range(N):
        for a, amp in enumerate((4.0, 3.0)):
            theta[:, m, a] = np.deg2rad(amp) * np.sin(2 * np.pi * t / rng.uniform(8, 20) + rng.uniform(0, 6))
    actuator = 100 + 30 * np.sin(2 * np.pi * t / 13)[:, None, None] * np.ones((1, N, 3))
    reset = np.zeros(FRAMES, dtype=bool)
    reset[0] = True
    return theta, actuator, reset


def joint_side(case, params, enabled=("stick_slip",), **kw):
    theta, actuator, reset = case
    eff = Effects(enabled=enabled, params={"stick_slip": params})
    chain = transmit(theta, actuator, reset, RobotGeometry(n_modules=N), FrictionLaw(), eff, DT, **kw).chain
    return chain[:, np.arange(N), np.arange(N)][:, 1:]


@pytest.mark.skipif(not COMPILED, reason="the compiled pass needs numba")
def test_compiled_pass_is_the_reference_chain(moving):
    """The compiled solver and friction_models' reference agree to rounding, with every compiled effect."""
    enabled = ("contact", "stick_slip", "viscoelastic", "velocity_friction", "bending_stiffness", "per_tendon_wrap")
    params = {"driver": "elastic"}
    fast = joint_side(moving, params, enabled, compiled=True)
    ref = joint_side(moving, params, enabled, compiled=False)
    np.testing.assert_allclose(fast, ref, rtol=0, atol=1e-9)


def test_infinitely_stiff_tendon_is_the_motion_driver(moving):
    """EA -> inf (1e12 N) against the motion driver (slide threshold 1e-9 m/s).

    Tolerance: identical to 1e-6 N on >= 85 % of values; the rest differ where the exact
    hole-to-hole path (the elastic chain's) and the small-angle ``-r b`` (the motion driver's)
    change length in opposite directions, at reversals and for tendons whose azimuth is across
    the bend, where the small-angle change is zero: there the stiff tendon still slides.
    """
    stiff = joint_side(moving, {"driver": "elastic", "EA": 1e12})
    motion = joint_side(moving, {"driver": "motion", "slide_threshold": 1e-9})
    d = np.abs(stiff - motion)
    assert np.mean(d < 1e-6) >= 0.85
    assert np.percentile(d, 99) < 10.0


def test_infinitely_soft_tendon_is_the_tension_driver(moving):
    """EA -> 0 (1e-3 N) against the tension driver.

    Tolerance: RMS below 0.5 N and every value within 5 N.  They differ only where a band moves
    (the wraps change): the rigid play operator clamps each guide on its own, while a tendon of
    any stiffness conserves material across a slipping guide, so the segment before it gives up
    what the segment after it takes.  With the wraps held still they agree to 1e-9 N
    (tests/friction_models/test_elastic_chain.py).
    """
    soft = joint_side(moving, {"driver": "elastic", "EA": 1e-3})
    tension = joint_side(moving, {"driver": "tension"})
    d = soft - tension
    assert np.sqrt(np.mean(d**2)) < 0.5
    assert np.abs(d).max() < 5.0


def test_exact_path_lengths_change_by_minus_r_b_at_small_bends():
    """The crossing length is the joint gap when straight and changes by -r b(psi) to first order."""
    geo = RobotGeometry(n_modules=3)
    theta = np.zeros((2, 3, 2))
    theta[1, 1:, 0] = 1e-4
    lengths = segment_path_lengths(theta, geo)
    np.testing.assert_allclose(lengths[0], geo.joint_gap, rtol=1e-12)
    psi = 2 * np.pi * np.arange(3) / 3 + np.arange(3)[:, None] * geo.azimuth_step
    want = -geo.hole_radius * 1e-4 * np.cos(psi)
    np.testing.assert_allclose(lengths[1] - lengths[0], np.broadcast_to(want, lengths[1].shape), atol=1e-9)


def test_the_elastic_driver_refuses_the_rigid_chains_smooth_edge():
    with pytest.raises(ConfigError, match="elastic"):
        Effects(enabled=("stick_slip",), params={"stick_slip": {"driver": "elastic", "edge": "smooth"}})
    with pytest.raises(ConfigError, match="EA"):
        Effects(enabled=("stick_slip",), params={"stick_slip": {"driver": "elastic", "EA": -1.0}})
