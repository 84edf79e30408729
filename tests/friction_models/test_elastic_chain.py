"""The elastic tendon chain (friction_models/elastic_chain.py): its limits, its bands, its energy."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from friction_models import play_operator_edges
from friction_models.elastic_chain import elastic_chain


def play_cascade(t_in, phi, reset):
    """The tension driver: each guide's play operator in turn (paper §III-B), the rigid limit's reference."""
    x = np.log(t_in)
    out = []
    for s in range(phi.shape[1]):
        x = play_operator_edges(x - phi[:, s], x + phi[:, s], reset).log_out
        out.append(np.exp(x))
    return np.stack(out, axis=1)


def chain_case(seed, frames=300, n=5, motion=1e-4):
    rng = np.random.default_rng(seed)
    t = np.arange(frames)
    t_in = 120 + 50 * np.sin(t / rng.uniform(5, 15)) + 10 * rng.standard_normal(frames)
    phi = np.clip(0.06 + 0.03 * np.sin(t[:, None] / rng.uniform(4, 9, n)), 0.0, None)
    d_length = motion * rng.standard_normal((frames, n))
    reset = np.zeros(frames, dtype=bool)
    reset[0] = True
    return t_in, d_length, phi, reset


@pytest.mark.parametrize("stiffness", [1e-3, 1.0, 5e5, 1e12])
def test_with_the_path_held_it_is_the_play_operator_of_each_guide_for_any_stiffness(stiffness):
    """No joint moves and the bands hold still: only the tension drives slip, whatever EA (tolerance 1e-9 N)."""
    t_in, _, phi, reset = chain_case(0)
    phi = np.broadcast_to(phi[:1], phi.shape)  # fixed wraps
    got, _ = elastic_chain(t_in, np.zeros_like(phi), phi, np.full(phi.shape[1], stiffness), reset)
    np.testing.assert_allclose(got, play_cascade(t_in, phi, reset), rtol=0, atol=1e-9)


def test_a_soft_tendon_ignores_path_changes():
    """EA -> 0 relative to the length changes: the joints' motion changes nothing (tolerance 1e-6 N)."""
    t_in, d_length, phi, reset = chain_case(1)
    soft = np.full(phi.shape[1], 1e-6)
    moving, _ = elastic_chain(t_in, d_length, phi, soft, reset)
    still, _ = elastic_chain(t_in, np.zeros_like(d_length), phi, soft, reset)
    np.testing.assert_allclose(moving, still, rtol=0, atol=1e-6)


def test_a_stiff_tendon_is_drawn_through_the_guides_as_its_path_beyond_changes():
    """EA -> inf: a guide slips towards the side whose path shortens (the motion driver's rule)."""
    t_in, d_length, phi, reset = chain_case(2, motion=1e-4)
    t_in[:] = 120.0  # no tension change: only the motion acts
    _, sigma = elastic_chain(t_in, d_length, phi, np.full(phi.shape[1], 1e12), reset)
    beyond = np.cumsum(d_length[:, ::-1], axis=1)[:, ::-1]  # path change beyond each guide [m]
    moving = np.abs(beyond) > 1e-9
    moving[0] = False
    # Lengthening beyond the guide draws the tendon distally (reverse slip), shortening proximally.
    np.testing.assert_array_equal(sigma[moving], np.where(beyond[moving] > 0, -1, 1))


def flows(tension, t_in, d_length, stiffness):
    """Material p_s [m] that passed guide s towards the actuator in each frame, from the tensions."""
    prev = np.vstack([tension[:1], tension[:-1]])
    trial = prev + stiffness * d_length
    per_segment = (tension - trial) / stiffness  # p_s - p_{s+1}
    p = np.cumsum(per_segment[:, ::-1], axis=1)[:, ::-1]
    p[0] = 0.0
    return p


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), log_k=st.floats(3.0, 7.0))
def test_material_passes_a_guide_only_on_the_edge_of_its_direction_so_friction_never_gives_energy(seed, log_k):
    """Coulomb's law at every guide: the friction work ``p_s (T_{s-1} - T_s)`` is >= 0 in every frame."""
    t_in, d_length, phi, reset = chain_case(seed, frames=120, n=4)
    k = np.full(phi.shape[1], 10.0**log_k)
    tension, sigma = elastic_chain(t_in, d_length, phi, k, reset)
    p = flows(tension, t_in, d_length, k)
    upstream = np.hstack([t_in[:, None], tension[:, :-1]])
    work = p * (upstream - tension)
    tol = 1e-9 * np.abs(upstream) / k  # the solver's tolerance in material
    assert np.all(work >= -1e-9 * np.abs(upstream))
    assert np.all(sigma[p > tol] == 1)
    assert np.all(sigma[p < -tol] == -1)


def test_each_closed_cycle_dissipates_energy():
    """Work in (actuator and joints) minus the change of stored elastic energy is >= 0 over each cycle."""
    n, frames, period = 4, 400, 100
    t = np.arange(frames)
    t_in = 120 + 60 * np.sin(2 * np.pi * t / period)
    d_length = 2e-5 * np.cos(2 * np.pi * t[:, None] / period + np.arange(n))  # paths cycle too
    phi = np.full((frames, n), 0.08)
    reset = np.zeros(frames, dtype=bool)
    reset[0] = True
    k = np.full(n, 5e5)
    tension, _ = elastic_chain(t_in, d_length, phi, k, reset)
    p = flows(tension, t_in, d_length, k)
    energy = 0.5 * (tension**2 / k).sum(axis=1)
    # Work done on the tendon over frame t: the actuator reels in p_1 at T_0, the joints stretch each
    # segment by dL_s at T_s (end-of-frame tensions: the implicit step's own work).
    work = t_in * p[:, 0] + (tension * d_length).sum(axis=1)
    for start in range(period, frames - period, period):
        cycle = slice(start + 1, start + period + 1)
        dissipated = work[cycle].sum() - (energy[start + period] - energy[start])
        assert dissipated >= 0.0
        assert dissipated > 1e-6  # a cycle through stick and slip loses something


def test_viscoelastic_tendon_stays_inside_every_band():
    """The standard-linear-solid tendon relaxes, but each guide's output stays in its Coulomb band."""
    t_in, d_length, phi, reset = chain_case(3)
    t_in = np.where(np.arange(t_in.size) < 150, 100.0, 200.0)  # the step of the issue: 100 -> 200 N
    tension, _ = elastic_chain(t_in, d_length, phi, np.full(phi.shape[1], 5e5), reset, dt=0.1, tau=1.5, kappa=0.3)
    upstream = np.hstack([t_in[:, None], tension[:, :-1]])
    assert np.all(tension >= upstream * np.exp(-phi) * (1 - 1e-12))
    assert np.all(tension <= upstream * np.exp(phi) * (1 + 1e-12))
