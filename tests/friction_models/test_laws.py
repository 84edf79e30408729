import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from friction_models import (
    affine_cosine_mu,
    bending_loss,
    capstan_exponent,
    capstan_ratio,
    constant_mu,
    guide_wear_factors,
    hard_contact_gate,
    smooth_contact_gate,
    speed_factor,
    velocity_dependent_mu,
    viscoelastic_lag,
)

coef = st.floats(-1, 1, allow_nan=False)
ALPHA = np.linspace(0.0, np.pi, 721)


@settings(max_examples=300, deadline=None)
@given(A=coef, B=coef)
def test_affine_cosine_is_nonnegative_on_0_pi_iff_B_ge_abs_A(A, B):
    # docs/guide/calibration.rst: mu(alpha) >= 0 on [0, pi]  <=>  B >= |A| (cos spans [-1, 1] there).
    assume(abs(B - abs(A)) > 1e-9)  # away from the edge, where rounding decides
    nonneg = bool(np.all(affine_cosine_mu(ALPHA, A, B) >= 0.0))
    assert nonneg == (B >= abs(A))


def test_affine_cosine_golden_values():
    # Independent derivation: cos(0) = 1, cos(pi/2) = 0, cos(pi) = -1.
    A, B = np.array([0.30, 0.32, 0.28]), np.array([0.09, 0.08, 0.10])
    np.testing.assert_allclose(affine_cosine_mu(0.0, A, B), A + B)
    np.testing.assert_allclose(affine_cosine_mu(np.pi / 2, A, B), B, atol=1e-15)
    np.testing.assert_allclose(affine_cosine_mu(np.pi, A, B), B - A)


@settings(max_examples=100, deadline=None)
@given(mu=st.floats(0, 2), alpha=st.floats(0, np.pi))
def test_capstan_ratio_is_euler_eytelwein(mu, alpha):
    phi = capstan_exponent(mu, alpha)
    r = capstan_ratio(phi)
    assert 0 < r <= 1
    assert r == pytest.approx(np.exp(-mu * alpha), rel=1e-12)
    assert capstan_ratio(phi, sigma=-1) == pytest.approx(1 / r, rel=1e-12)
    assert capstan_ratio(phi, sigma=0) == 1.0
    assert capstan_exponent(mu, alpha, beta=0.0) == 0.0


def test_constant_mu_broadcasts():
    assert constant_mu(np.zeros((4, 3)), [0.1, 0.2, 0.3]).shape == (4, 3)


@settings(max_examples=100, deadline=None)
@given(alpha=st.floats(0, np.pi), alpha_c=st.floats(0, 0.5))
def test_contact_gates(alpha, alpha_c):
    hard = hard_contact_gate(alpha, alpha_c)
    assert hard == (1.0 if alpha > alpha_c else 0.0)
    soft = smooth_contact_gate(alpha, alpha_c, width=1e-6)
    assert 0.0 <= soft <= 1.0
    if abs(alpha - alpha_c) > 1e-4:
        assert soft == pytest.approx(hard, abs=1e-6)


def test_smooth_gate_is_monotone_and_half_at_clearance():
    g = smooth_contact_gate(ALPHA, 0.3, 0.05)
    assert np.all(np.diff(g) >= 0)
    assert smooth_contact_gate(0.3, 0.3, 0.05) == pytest.approx(0.5)
    with pytest.raises(ValueError):
        smooth_contact_gate(0.1, 0.1, width=0)
    with pytest.raises(ValueError):
        hard_contact_gate(0.1, -0.1)


def test_velocity_friction():
    mu = np.array([0.3, 0.4])
    np.testing.assert_allclose(velocity_dependent_mu(mu, 0.0), mu)
    np.testing.assert_allclose(velocity_dependent_mu(mu, 0.01, v_ref=0.01), 2 * mu)
    # Sign of the speed does not matter; a Stribeck dip lowers mu at moderate speed.
    np.testing.assert_allclose(velocity_dependent_mu(mu, -0.004, 0.01), velocity_dependent_mu(mu, 0.004, 0.01))
    assert np.all(velocity_dependent_mu(mu, 0.003, v_ref=1.0, stribeck_drop=0.3, v_stribeck=0.002) < mu)
    with pytest.raises(ValueError):
        velocity_dependent_mu(mu, 0.0, v_ref=0.0)


@settings(max_examples=200, deadline=None)
@given(v=st.floats(-0.05, 0.05), slope=st.floats(-1000.0, 2000.0))
def test_speed_factor_is_viscous_or_weakening_by_its_slope_at_rest(v, slope):
    f = float(speed_factor(v, slope))
    assert f > 0.0  # friction never changes sign, however fast the tendon slides
    if slope > 0:  # viscous: the simulator's law without its dip, v_ref = 1 / slope
        assert f == pytest.approx(float(velocity_dependent_mu(1.0, v, v_ref=1.0 / slope)))
    elif slope < 0:  # weakening: below 1, the more the faster
        assert f <= 1.0 and float(speed_factor(2 * v, slope)) <= f
    h = 1e-7  # the slope at rest is the parameter, on both branches
    assert (float(speed_factor(h, slope)) - 1.0) / h == pytest.approx(slope, rel=1e-3, abs=1e-6)
    assert float(speed_factor(0.0, slope)) == 1.0 and float(speed_factor(v, 0.0)) == 1.0


def sequential_lag(x, a, kappa, reset):
    z = np.empty_like(x)
    for t in range(len(x)):
        z[t] = x[t] if (t == 0 or reset[t]) else a * z[t - 1] + (1 - a) * x[t]
    return (1 - kappa) * x + kappa * z


@settings(max_examples=100, deadline=None)
@given(n=st.integers(1, 60), tau=st.floats(0.05, 10), kappa=st.floats(0, 1), seed=st.integers(0, 10))
def test_viscoelastic_scan_matches_loop(n, tau, kappa, seed):
    rng = np.random.default_rng(seed)
    x = rng.uniform(50, 150, size=n)
    reset = rng.uniform(size=n) < 0.1
    out = viscoelastic_lag(x, 0.1, tau, kappa, reset)
    np.testing.assert_allclose(out, sequential_lag(x, np.exp(-0.1 / tau), kappa, reset), rtol=1e-12)


def test_viscoelastic_step_response():
    x = np.r_[np.full(10, 100.0), np.full(200, 150.0)]
    out = viscoelastic_lag(x, 0.1, 1.0, 0.4)
    assert out[9] == pytest.approx(100.0)  # relaxed at rest: DC gain 1
    assert out[10] == pytest.approx(100 + 50 * (0.6 + 0.4 * (1 - np.exp(-0.1))), rel=1e-12)
    assert out[-1] == pytest.approx(150.0, rel=1e-6)
    with pytest.raises(ValueError):
        viscoelastic_lag(x, 0.1, 1.0, 1.5)


def test_bending_loss_and_wear():
    assert bending_loss(0.5, 4.0) == pytest.approx(2.0)
    with pytest.raises(ValueError):
        bending_loss(0.5, -1.0)
    w = guide_wear_factors(11, {4: 1.8, 8: 1.5})
    assert w[3] == 1.8 and w[7] == 1.5 and w.sum() == pytest.approx(9 + 3.3)
    with pytest.raises(ValueError):
        guide_wear_factors(11, {12: 1.5})
    with pytest.raises(ValueError):
        guide_wear_factors(11, {2: 0.0})
