"""The plant's statics (issue 40): every tendon that crosses a joint pulls on it, gravity, inertia, energy."""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tendon_id.closed_loop import JointDynamics, Plant
from tendon_id.closed_loop.statics import (
    composite_inertia,
    crossing_jacobian,
    elastic_energy,
    elastic_return,
    gravity_moments,
    link_frames,
    on_path,
    tendon_moments,
)
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.geometry import RobotGeometry, crossing_length, joint_rotation, tendon_azimuths
from tendon_id.sim import FrictionLaw
from tendon_id.sim.body import STANDARD_GRAVITY, Body

FULL = JointDynamics(statics="full")


def _frictionless(n_modules=12, body=None, **robot):
    """snake12-paper's robot without friction (to 1e-12) or effects: a tendon's tension is the same throughout."""
    recipe = load_recipe("snake12-paper")
    return replace(
        recipe,
        robot=replace(recipe.robot, n_modules=n_modules, **robot),
        friction=FrictionLaw(A=(1e-12,) * 3, B=(0.0,) * 3),  # mu(0) must be positive: 1e-12 is none
        effects=recipe.effects.with_enabled([]),
        body=body or Body(),
    )


def _hand_planar_moments(a, chain, geometry, gain, body, sectors):
    """Moments about each joint of a pose bent in the x-z plane only (theta_y = 0), derived by hand.

    Across a joint bent by ``a`` the segment from hole ``(ux, uy, -h)`` to the rotated hole
    ``R_y(a) (ux, uy, h)`` is ``s = (ux (cos a - 1) + h sin a, 0, h (1 + cos a) - ux sin a)``, so
    ``l^2 = 2 ux^2 (1 - cos a) + 2 h^2 (1 + cos a) - 4 ux h sin a``, ``dl/da = ((ux^2 - h^2) sin a
    - 2 ux h cos a) / l`` and, differentiating ``R_x(-b)`` at ``b = 0``, ``dl/db = -uy (h (1 + cos a)
    - ux sin a) / l``.  The elastic return is ``-g r sum_i [a cos psi_i]_+ (cos psi_i, sin psi_i)``.
    Gravity along the base's +x acts on a planar chain about the y axis only, with lever arm the
    base-z distance from the pivot: ``tau_x = g sum m (z_m - z_pivot)``.
    """
    n = len(a)
    psi = tendon_azimuths(geometry)
    r, h = geometry.hole_radius, 0.5 * geometry.joint_gap
    tau = np.zeros((n, 2))
    for k in range(n):
        ca, sa = np.cos(a[k]), np.sin(a[k])
        for j in range(k, n):
            for i in range(3):
                ux, uy = r * np.cos(psi[j, i]), r * np.sin(psi[j, i])
                length = np.sqrt(2 * ux**2 * (1 - ca) + 2 * h**2 * (1 + ca) - 4 * ux * h * sa)
                dl_da = ((ux**2 - h**2) * sa - 2 * ux * h * ca) / length
                dl_db = -uy * (h * (1 + ca) - ux * sa) / length
                tau[k] -= chain[k, j, i] * np.array([dl_da, dl_db])
        if not sectors:  # the backbone: -g r theta
            tau[k, 0] -= r * gain * a[k]
            continue
        for i in range(3):
            u = np.array([np.cos(psi[k, i]), np.sin(psi[k, i])])
            tau[k] -= r * gain * max(a[k] * u[0], 0.0) * u
    # Gravity: a chain in the base's x-z plane; beta_k the direction of link k from the base's z axis.
    pitch, length_l = geometry.link_length + geometry.joint_gap, geometry.link_length
    beta = np.cumsum(a)
    z_pivot = np.concatenate([[0.0], np.cumsum(pitch * np.cos(beta))[:-1]])
    z_centre = z_pivot + (h + 0.5 * length_l) * np.cos(beta)
    z_tip = z_pivot[-1] + (h + length_l) * np.cos(beta[-1])
    for k in range(n):
        arm = body.link_mass_kg * np.sum(z_centre[k:] - z_pivot[k]) + body.payload_kg * (z_tip - z_pivot[k])
        tau[k, 0] += STANDARD_GRAVITY * arm
    return tau


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-0.6, 0.6), min_size=4, max_size=4), st.integers(0, 2**32 - 1), st.booleans())
def test_the_plants_statics_match_statics_derived_by_hand(bends, seed, sectors):
    """A 4-module pose bent in one plane, every tendon at its own tension, with gravity and a payload: the
    plant's moment on each joint (tendons crossing it, elastic return, gravity) is the hand-derived one to 1e-9 N m."""
    body = Body(gravity=True, payload_kg=0.05, base_tilt_deg=90.0, base_azimuth_deg=0.0)
    recipe = _frictionless(n_modules=4, body=body)
    dynamics = JointDynamics(statics="full", elastic_return="sectors" if sectors else "backbone")
    plant = Plant(recipe, batch=1, dynamics=dynamics)
    chain = np.random.default_rng(seed).uniform(20.0, 300.0, (4, 4, 3)) * on_path(4)[:, :, None]
    theta = np.zeros((1, 4, 2))
    theta[0, :, 0] = bends
    ours = plant.static_moments(theta, chain[None])[0] + plant.elastic_moments(theta)[0]
    hand = _hand_planar_moments(np.array(bends), chain, recipe.robot, recipe.actuation.gain_n_per_rad, body, sectors)
    np.testing.assert_allclose(ours, hand, rtol=0, atol=1e-9)


def test_the_tendon_jacobian_is_the_first_order_one_near_straight():
    """At small bends ``dl/dtheta = -r (cos psi, sin psi)``: the own-set plant's moment, ``r sum T u``."""
    geometry = RobotGeometry(n_modules=3)
    jac = crossing_jacobian(np.full((3, 2), 1e-9), geometry)
    psi = tendon_azimuths(geometry)
    first = -geometry.hole_radius * np.stack([np.cos(psi), np.sin(psi)], axis=-1)
    for k in range(3):
        np.testing.assert_allclose(jac[k, k:], first[k:], atol=1e-10)
        assert not jac[k, :k].any()  # sets that end before joint k do not cross it


def test_distal_tendons_pulling_unequally_move_joint_1():
    """Set 12's tendons cross every joint: pulling one of them harder bends joint 1 too, which the own-set
    plant (each joint driven by its own set only) never shows.  At 30 N the 36 tendons' geometric
    softening at joint 1 (``sum T h / 2`` = 2.7 N m/rad) stays below its elastic return (6-12 N m/rad), so
    the joint, left to itself, comes to rest; at the 80 N pretension it would not (the closed loop holds it)."""
    recipe = _frictionless()
    command = np.full((1, 12, 3), 30.0)
    command[0, 11, 0] += 30.0
    moved = {}
    for statics in ("full", "own_set"):
        plant = Plant(recipe, batch=1, dynamics=JointDynamics(statics=statics))
        plant.reset(command)
        plant.advance(command, 1.0)
        moved[statics] = np.rad2deg(np.linalg.norm(plant.theta[0, 0]))
    assert moved["full"] > 0.5  # degrees: 30 N at 12 mm is 0.36 N m against 6-12 N m/rad
    assert moved["own_set"] < 1e-9
    plant = Plant(recipe, batch=1, dynamics=FULL)
    plant.reset(command)
    plant.advance(command, 5.0)  # joint 1 carries the whole chain: a few rad/s, critically damped
    load = plant.static_moments(plant.theta, plant.chain)[0, 0]
    assert np.linalg.norm(load) > 0.3  # N m: the distal set's pull, less the others' geometric share
    balance = load + plant.elastic_moments(plant.theta)[0, 0]
    assert np.linalg.norm(balance) < 1e-2 * np.linalg.norm(load)  # at rest: the elastic return holds it


def test_an_unactuated_cantilever_sags_under_its_weight():
    """Horizontal, gravity on, tendons all but slack: at the straight pose each joint carries the closed-form
    moment ``g (m sum_k d_k + m_p d_tip)`` of the links and payload beyond it, and the plant comes to rest
    where the joints' stiffness balances gravity at the sagged pose."""
    body = Body(gravity=True, payload_kg=0.2, base_tilt_deg=90.0)
    recipe = _frictionless(n_modules=3, body=body)
    geometry = recipe.robot
    pitch, h, length = geometry.link_length + geometry.joint_gap, 0.5 * geometry.joint_gap, geometry.link_length
    straight = gravity_moments(np.zeros((3, 2)), geometry, body)
    for k in range(3):
        arms = [(m - k) * pitch + h + length / 2 for m in range(k, 3)]
        tip = (2 - k) * pitch + h + length
        closed_form = STANDARD_GRAVITY * (body.link_mass_kg * sum(arms) + body.payload_kg * tip)
        assert straight[k, 0] == pytest.approx(closed_form, rel=1e-12)
        assert straight[k, 1] == pytest.approx(0.0, abs=1e-15)  # no moment about the other axis
    stiffness = 40.0
    plant = Plant(recipe, batch=1, dynamics=JointDynamics(statics="full", stiffness=stiffness))
    slack = np.full((1, 3, 3), 1e-6)  # the stepper needs positive tensions; their moments are ~1e-8 N m
    plant.reset(slack)
    plant.advance(slack, 4.0)
    residual = -stiffness * plant.theta[0] + plant.static_moments(plant.theta, plant.chain)[0]
    assert np.abs(residual).max() < 1e-6  # N m, at rest
    assert np.all(plant.theta[0, :, 0] > 0) and np.abs(plant.theta[0, :, 1]).max() < 1e-12  # sags towards +x
    np.testing.assert_allclose(plant.theta[0, :, 0], straight[:, 0] / stiffness, rtol=0.05)  # small sag


def _energy(plant, chain_tension):
    """Kinetic, elastic, gravity and the tendons' ``T l`` potential [J] of a frictionless plant, per robot."""
    g = plant.geometry
    psi = tendon_azimuths(g)
    kinetic = 0.5 * np.sum(plant.inertia[None, :, None] * plant.omega**2, axis=(1, 2))
    if plant.isotropic:  # the backbone: K |theta|^2 / 2 per joint
        elastic = 0.5 * plant.stiffness * np.sum(plant.theta**2, axis=(1, 2))
    else:
        elastic = elastic_energy(plant.theta, psi, plant.gain, g.hole_radius)
    rot, piv = link_frames(plant.theta, g)
    h = 0.5 * g.joint_gap
    centre = piv + (h + 0.5 * g.link_length) * rot[..., :, 2]
    tip = piv[..., -1, :] + (h + g.link_length) * rot[..., -1, :, 2]
    gb = plant.recipe.body.gravity_in_base()
    gravity = -(plant.recipe.body.link_mass_kg * np.sum(centre @ gb, axis=-1) + plant.recipe.body.payload_kg * tip @ gb)
    # The tendons: the crossing lengths change, the rest of each tendon does not (constant tension: T l).
    R = joint_rotation(plant.theta)[..., :, None, None, :, :]
    lengths = crossing_length(R, g.hole_radius * np.cos(psi), g.hole_radius * np.sin(psi), h)
    tendons = np.sum(chain_tension[:, None] * lengths * on_path(g.n_modules)[:, :, None], axis=(1, 2, 3))
    return kinetic + elastic + gravity + tendons


def _energy_drift(dt, elastic_return):
    """Relative change of the total energy of an undamped, frictionless 4-module robot over 0.1 s."""
    body = Body(gravity=True, payload_kg=0.1, base_tilt_deg=60.0, base_azimuth_deg=40.0)
    recipe = _frictionless(n_modules=4, body=body)
    dynamics = JointDynamics(statics="full", damping_ratio=0.0, elastic_return=elastic_return)
    plant = Plant(recipe, batch=1, dynamics=dynamics, dt=dt)
    tension = np.random.default_rng(0).uniform(60.0, 120.0, (1, 4, 3))
    plant.reset(tension)
    plant.theta = np.random.default_rng(1).uniform(-0.1, 0.1, (1, 4, 2))
    plant.joint_side, plant.sigma = plant.stepper.step(plant.theta, plant.actuator)
    start = _energy(plant, tension)[0]
    swing = 0.0
    for _ in range(10):
        plant.advance(tension, 0.01)
        swing = max(swing, np.abs(plant.omega).max())
    np.testing.assert_allclose(plant.chain[0][on_path(4)], np.broadcast_to(tension[0], (4, 4, 3))[on_path(4)])
    assert swing > 0.5  # rad/s: it does move
    kinetic = 0.5 * np.sum(plant.inertia[None, :, None] * plant.omega**2)
    return abs(_energy(plant, tension)[0] - start) / kinetic


@pytest.mark.parametrize("elastic_return", ["backbone", "sectors"])
def test_the_plant_conserves_energy_without_damping_or_friction(elastic_return):
    """The elastic return is integrated exactly (zero-order hold per sector); the tendons' and gravity's
    moments are held over each step, which leaks energy at first order in the step.  So the leak is small
    and halves with the step: a missing or wrong moment would leak at every step size alike."""
    coarse, fine = _energy_drift(2e-5, elastic_return), _energy_drift(1e-5, elastic_return)
    assert fine < 5e-3
    assert 1.6 < coarse / fine < 2.5


def test_composite_inertia_by_the_parallel_axis_theorem():
    geometry, body = RobotGeometry(n_modules=2), Body(link_mass_kg=0.05, link_radius_m=0.01, payload_kg=0.1)
    own = 0.05 * (geometry.link_length**2 / 12 + 0.01**2 / 2)
    h, length, pitch = 0.5 * geometry.joint_gap, geometry.link_length, geometry.link_length + geometry.joint_gap
    last = own + 0.05 * (h + length / 2) ** 2 + 0.1 * (h + length) ** 2
    first = 2 * own + 0.05 * ((h + length / 2) ** 2 + (pitch + h + length / 2) ** 2) + 0.1 * (pitch + h + length) ** 2
    np.testing.assert_allclose(composite_inertia(geometry, body), [first, last], rtol=1e-12)


def test_the_elastic_return_is_stiffer_towards_a_tendon_than_between_two():
    psi = np.array([[0.0, 2 * np.pi / 3, 4 * np.pi / 3]])
    towards = elastic_return(np.array([[0.01, 0.0]]), psi, 600.0, 0.012)
    between = elastic_return(0.01 * np.array([[np.cos(np.pi / 3), np.sin(np.pi / 3)]]), psi, 600.0, 0.012)
    assert np.linalg.norm(towards) == pytest.approx(600 * 0.012 * 0.01)
    assert np.linalg.norm(between) == pytest.approx(0.5 * 600 * 0.012 * 0.01)


def test_the_sector_return_has_no_stiffness_across_a_bend_towards_one_tendon():
    """Why the backbone is the default: within 30 deg of a tendon only that tendon's share pulls, so the
    sectors' return has no stiffness across that tendon, and any tension (whose geometric softening is
    negative) makes the joint unstable there.  A 1 mrad step across the tendon changes the return not at
    all (to rounding) at a bend 10 deg from it; between two tendons (60 deg) a step across the bend meets
    3 g r / 2 (``u_1 u_1^T + u_2 u_2^T`` across the bend: cos^2 30 deg twice)."""
    psi = np.array([[0.0, 2 * np.pi / 3, 4 * np.pi / 3]])
    g, r = 1000.0, 0.012
    for azimuth, across, expected in (
        (np.deg2rad(10.0), np.array([0.0, 1.0]), 0.0),
        (np.pi / 3, np.array([-np.sin(np.pi / 3), np.cos(np.pi / 3)]), 1.5 * g * r),
    ):
        bend = 0.05 * np.array([np.cos(azimuth), np.sin(azimuth)])
        change = elastic_return((bend + 1e-3 * across)[None], psi, g, r) - elastic_return(bend[None], psi, g, r)
        assert -change[0] @ across / 1e-3 == pytest.approx(expected, abs=1e-9)


def test_the_backbone_return_is_isotropic():
    recipe = load_recipe("snake12-paper")
    plant = Plant(recipe, batch=1, dynamics=FULL)
    theta = np.random.default_rng(3).uniform(-0.1, 0.1, (1, 12, 2))
    k = recipe.actuation.gain_n_per_rad * recipe.robot.hole_radius
    np.testing.assert_allclose(plant.elastic_moments(theta), -k * theta, rtol=1e-12)
    sectors = Plant(recipe, batch=1, dynamics=JointDynamics(statics="full", elastic_return="sectors"))
    np.testing.assert_allclose(
        sectors.elastic_moments(theta), elastic_return(theta, sectors.psi, recipe.actuation.gain_n_per_rad, 0.012)
    )


def test_tendon_moments_ignore_entries_off_the_path():
    """A model's chain is NaN where a set does not cross a joint; those entries are not read."""
    geometry = RobotGeometry(n_modules=3)
    jac = crossing_jacobian(np.zeros((3, 2)), geometry)
    chain = np.full((3, 3, 3), 50.0)
    nan_chain = np.where(on_path(3)[:, :, None], chain, np.nan)
    np.testing.assert_array_equal(tendon_moments(nan_chain, jac), tendon_moments(chain, jac))


def test_bad_body_and_dynamics_settings_are_refused():
    with pytest.raises(ConfigError, match="payload_kg"):
        Body(payload_kg=-1.0)
    with pytest.raises(ConfigError, match="base_tilt_deg"):
        Body(base_tilt_deg=200.0)
    with pytest.raises(ConfigError, match="statics"):
        JointDynamics(statics="everything")
    with pytest.raises(ConfigError, match="elastic_return"):
        JointDynamics(elastic_return="springs")
    with pytest.raises(ConfigError, match=r"\[body\]"):
        from tendon_id.sim import Recipe

        Recipe.from_dict({"name": "x", "body": {"mass": 1.0}})


def test_a_recipe_without_a_body_keeps_its_fingerprint():
    recipe = load_recipe("snake12-paper")
    assert "body" not in recipe.to_dict()
    heavy = replace(recipe, body=Body(gravity=True))
    assert heavy.fingerprint() != recipe.fingerprint()
    from tendon_id.sim import Recipe

    read = Recipe.from_dict({"name": "x", "body": {"gravity": True, "payload_kg": 0.3}})
    assert read.body == Body(gravity=True, payload_kg=0.3)
