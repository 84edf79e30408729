import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from tendon_id.errors import ConfigError
from tendon_id.geometry import (
    RobotGeometry,
    backbone_wrap,
    contact_gate,
    exact_wrap,
    joint_rotation,
    projected_bend,
    projected_wrap,
    tendon_azimuths,
)

GEOM = RobotGeometry(n_modules=5)
angle = st.floats(-0.5, 0.5, allow_nan=False)
poses = arrays(float, (3, 5, 2), elements=angle)


@settings(max_examples=100, deadline=None)
@given(theta=poses)
def test_backbone_wrap_range_and_symmetry(theta):
    w = backbone_wrap(theta, GEOM.alpha_0)
    assert w.shape == (3, 4)
    assert np.all(w >= GEOM.alpha_0 - 1e-15) and np.all(w <= np.pi)
    np.testing.assert_array_equal(w, backbone_wrap(-theta, GEOM.alpha_0))
    # Rotating every bend about the backbone leaves the backbone wrap unchanged.
    c, s = np.cos(0.7), np.sin(0.7)
    rot = np.stack([c * theta[..., 0] - s * theta[..., 1], s * theta[..., 0] + c * theta[..., 1]], axis=-1)
    np.testing.assert_allclose(w, backbone_wrap(rot, GEOM.alpha_0), atol=1e-14)


def test_backbone_wrap_golden():
    # Guide 1 between a 0.2 rad bend and a (0.3, 0.4) bend: 0.1 + 0.25 + alpha_0.
    theta = np.array([[[0.2, 0.0], [0.3, 0.4]]])
    assert backbone_wrap(theta, 0.05)[0, 0] == pytest.approx(0.4)


@settings(max_examples=100, deadline=None)
@given(
    direction=arrays(float, (2, 5, 2), elements=st.floats(-1.0, 1.0)),
    psi=arrays(float, (5, 3), elements=st.floats(0.0, 2.0 * np.pi)),
    scale=st.sampled_from([0.01, 0.05, 0.15]),
)
def test_projected_wrap_is_the_exact_wrap_to_second_order(direction, psi, scale):
    # Small bends in every direction, tendons at any azimuth: the expansion's error is third order
    # in the bends (0.45 sum |theta|^3 at most for this robot's r / h; bounded here at 1), where the
    # backbone wrap, its first-order part, is off at second order.
    theta = scale * direction
    e = exact_wrap(theta, GEOM, psi)
    p = projected_wrap(theta, GEOM, psi)
    assert p.shape == e.shape == (2, 4, 5, 3)
    mag = np.linalg.norm(theta, axis=-1)
    cubic = (mag[:, :-1] ** 3 + mag[:, 1:] ** 3)[..., None, None]
    assert np.all(np.abs(p - e) <= cubic + 1e-12)
    np.testing.assert_allclose(projected_wrap(theta, GEOM, psi, alpha_0=0.0), p - GEOM.alpha_0, atol=1e-15)


def test_projected_wrap_is_the_turn_not_the_length_change():
    # A 10 deg bend of two neighbouring joints, a tendon at psi = 120 deg: the tendon turns by half
    # of each bend at its holes (12.9 deg with the routing wrap), though its length changes by half
    # as much as in the bending plane (the projected bend, cos 120 deg = -1/2: 7.9 deg).
    theta = np.zeros((1, 5, 2))
    theta[0, 1:3, 0] = np.deg2rad(10.0)
    psi = np.full((5, 3), np.deg2rad(120.0))
    p, e = projected_wrap(theta, GEOM, psi)[0, 1, 0, 0], exact_wrap(theta, GEOM, psi)[0, 1, 0, 0]
    assert np.rad2deg(e) == pytest.approx(10.0 + np.rad2deg(GEOM.alpha_0))
    assert p == pytest.approx(e, abs=1e-12)  # one Cardan axis: no twist, the expansion is exact
    b = projected_bend(theta, psi)[0, 1:3, 0, 0]
    assert np.rad2deg(0.5 * np.abs(b).sum() + GEOM.alpha_0) == pytest.approx(7.86, abs=0.01)


@settings(max_examples=60, deadline=None)
@given(theta=arrays(float, (2, 5), elements=angle), which=st.sampled_from([0, 1]))
def test_exact_wrap_equals_backbone_for_single_axis_bends(theta, which):
    # With one Cardan axis at rest there is no twist, so the tendon turns by exactly
    # half of each joint's bend at every hole: the exact wrap is the backbone wrap.
    full = np.zeros((2, 5, 2))
    full[..., which] = theta
    e = exact_wrap(full, GEOM)
    b = backbone_wrap(full, GEOM.alpha_0)
    np.testing.assert_allclose(e, np.broadcast_to(b[..., None, None], e.shape), atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(theta=poses)
def test_exact_wrap_is_close_to_backbone_and_in_range(theta):
    e = exact_wrap(theta, GEOM)
    b = backbone_wrap(theta, GEOM.alpha_0)
    assert e.shape == (3, 4, 5, 3)
    assert np.all(e >= GEOM.alpha_0 - 1e-12) and np.all(e <= np.pi)
    # The Cardan twist is second order in the bends: |e - b| <= |theta|^2 scale.
    mag = np.linalg.norm(theta, axis=-1)
    bound = 2.0 * (mag[:, :-1] ** 2 + mag[:, 1:] ** 2) + 1e-9
    assert np.all(np.abs(e - b[..., None, None]) <= bound[..., None, None])


def test_on_path_only_matches_the_full_computation():
    rng = np.random.default_rng(0)
    theta = rng.uniform(-0.4, 0.4, size=(20, 5, 2))
    full = exact_wrap(theta, GEOM)
    part = exact_wrap(theta, GEOM, on_path_only=True)
    on_path = np.arange(1, 5)[:, None] < np.arange(1, 6)[None, :]
    np.testing.assert_array_equal(part[:, on_path], full[:, on_path])
    assert np.all(np.isnan(part[:, ~on_path]))


def test_straight_robot_has_only_the_routing_wrap():
    z = np.zeros((1, 5, 2))
    np.testing.assert_allclose(exact_wrap(z, GEOM), GEOM.alpha_0)
    np.testing.assert_allclose(backbone_wrap(z, GEOM.alpha_0), GEOM.alpha_0)


@settings(max_examples=100, deadline=None)
@given(theta=arrays(float, (4, 2), elements=st.floats(-1.5, 1.5)))
def test_joint_rotation_is_a_rotation_bending_the_axis_by_the_cardan_angle(theta):
    R = joint_rotation(theta)
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)
    # The link axis tilts by arccos(cos a cos b) towards (+x, +y) for positive angles.
    np.testing.assert_allclose(R[:, 2, 2], np.cos(theta[:, 0]) * np.cos(theta[:, 1]), atol=1e-12)


def test_azimuths_and_gate():
    psi = tendon_azimuths(RobotGeometry())
    assert psi.shape == (12, 3)
    np.testing.assert_allclose(psi[0], [0, 2 * np.pi / 3, 4 * np.pi / 3])
    np.testing.assert_allclose(psi[1, 0], 2 * np.pi / 36)
    g = RobotGeometry(alpha_c=0.1)
    np.testing.assert_array_equal(contact_gate(np.array([0.05, 0.1, 0.2]), g), [0, 0, 1])
    s = contact_gate(np.array([0.05, 0.2]), g, smooth=True, width=0.01)
    assert s[0] < 0.01 and s[1] > 0.99


def test_geometry_validation_and_round_trip():
    g = RobotGeometry(n_modules=7, alpha_0=0.02)
    assert RobotGeometry.from_dict(g.to_dict()) == g
    assert "hole_diameter" not in g.to_dict()  # unknown sizes stay out of metadata (and the recipe hash)
    sized = RobotGeometry(hole_diameter=1.3e-3, tendon_diameter=1.0e-3, hole_length=3e-3)
    assert RobotGeometry.from_dict(sized.to_dict()) == sized
    bad_sizes = ({"hole_diameter": 0.0}, {"hole_diameter": 1e-3, "tendon_diameter": 1e-3}, {"hole_length": "3 mm"})
    for bad in ({"n_modules": 1}, {"hole_radius": 0.0}, {"alpha_c": -0.1}, {"alpha_0": 2.0}) + bad_sizes:
        with pytest.raises(ConfigError):
            RobotGeometry(**bad)
    with pytest.raises(ConfigError, match="unknown robot setting"):
        RobotGeometry.from_dict({"n_modulez": 3})
