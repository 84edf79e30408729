"""The smooth edge of ``stick_slip`` (``edge = "smooth"``): off by default, physics when on."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from friction_models import affine_cosine_mu
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.geometry import backbone_wrap
from tendon_id.sim import EFFECT_OPTIONS, Effects, simulate
from tendon_id.sim.effects import BENCH_EDGE_WIDTH


@pytest.fixture(scope="module")
def recipe():
    return load_recipe("snake12-paper")


def _with(recipe, **stick_slip):
    effects = Effects(enabled=("stick_slip",), params={"stick_slip": stick_slip})
    return dataclasses.replace(recipe, effects=effects)


def _cone(recipe, res):
    """Guide ratios, their cone ``exp(-+phi)`` and the slip state, on the path only."""
    n = recipe.robot.n_modules
    alpha = backbone_wrap(res.theta_true, recipe.robot.alpha_0)[..., None, None]
    phi = np.broadcast_to(
        affine_cosine_mu(alpha, np.array(recipe.friction.A), np.array(recipe.friction.B)) * alpha,
        (res.chain.shape[0], n - 1, n, 3),
    )
    on_path = np.arange(1, n)[:, None] < np.arange(1, n + 1)[None, :]
    with np.errstate(invalid="ignore"):
        r = res.chain[:, 1:] / res.chain[:, :-1]
    return r[:, on_path], np.exp(-phi[:, on_path]), np.exp(phi[:, on_path]), res.sigma[:, on_path]


def test_off_by_default_and_the_width_alone_changes_nothing(recipe):
    d = Effects(enabled=("stick_slip",))
    assert d.get("stick_slip").edge == "sharp" and not d.has("smooth_edge")
    # A recipe's description (and so its fingerprint) is what it was before the option existed.
    assert d.to_dict()["params"]["stick_slip"] == {"driver": "tension", "slide_threshold": 1e-4}
    a = simulate(_with(recipe), "posterior-3", frames=500, seed=4)
    b = simulate(_with(recipe, edge="sharp", edge_width=0.9), "posterior-3", frames=500, seed=4)
    np.testing.assert_array_equal(a.chain, b.chain)
    np.testing.assert_array_equal(a.sigma, b.sigma)
    np.testing.assert_array_equal(a.recording.terminal, b.recording.terminal)


def test_smooth_edge_stays_in_the_cone_and_changes_the_output(recipe):
    smooth = _with(recipe, edge="smooth")
    assert smooth.effects.has("smooth_edge") and smooth.effects.get("stick_slip").edge_width == BENCH_EDGE_WIDTH
    res = simulate(smooth, "posterior-3", frames=800, seed=5)
    rr, lo, hi, sg = _cone(recipe, res)
    assert np.all(rr >= lo * (1 - 1e-12)) and np.all(rr <= hi * (1 + 1e-12))
    assert set(np.unique(sg)) == {-1, 0, 1}
    sharp = simulate(_with(recipe), "posterior-3", frames=800, seed=5)
    assert np.max(np.abs(res.chain - sharp.chain)[np.isfinite(res.chain)]) > 0.1  # [N]
    assert "edge" in smooth.effects.to_dict()["params"]["stick_slip"]  # and a smooth recipe says so


@settings(max_examples=8, deadline=None)
@given(st.floats(0.0, 1.0))
def test_width_to_zero_is_the_sharp_play_operator(recipe, w):
    """Log tensions move by at most ``w`` times the band's half-width per guide from the sharp edge's."""
    a = simulate(_with(recipe, edge="smooth", edge_width=w), "posterior-3", frames=200, seed=1)
    b = simulate(_with(recipe), "posterior-3", frames=200, seed=1)
    n = recipe.robot.n_modules
    _, lo, _, _ = _cone(recipe, b)
    half_band = -np.log(lo).max()  # the largest phi of a guide
    on = np.isfinite(a.chain)
    gap = np.abs(np.log(a.chain[on]) - np.log(b.chain[on]))
    assert gap.max() <= w * half_band * (n - 1) + 1e-9  # each guide adds at most w phi
    if w == 0:
        np.testing.assert_array_equal(a.chain, b.chain)


def test_no_jump_at_reversals(recipe):
    """A step of the output is no larger than the same step of the sharp edge, less a smooth corner."""
    smooth = simulate(_with(recipe, edge="smooth", edge_width=0.5), "planned-paths", frames=600, seed=2)
    sharp = simulate(_with(recipe), "planned-paths", frames=600, seed=2)
    steps = [np.nanmax(np.abs(np.diff(np.log(r.chain[:, -1, -1]), axis=0))) for r in (smooth, sharp)]
    assert steps[0] <= steps[1] + 1e-12


def test_motion_driver_with_a_smooth_edge_stays_in_the_cone(recipe):
    res = simulate(_with(recipe, driver="motion", edge="smooth"), "planned-paths", frames=400, seed=3)
    rr, lo, hi, _ = _cone(recipe, res)
    assert np.all(rr >= lo * (1 - 1e-12)) and np.all(rr <= hi * (1 + 1e-12))


def test_bad_settings_are_refused():
    with pytest.raises(ConfigError, match="edge_width"):
        Effects(enabled=("stick_slip",), params={"stick_slip": {"edge": "smooth", "edge_width": -0.1}})
    with pytest.raises(ConfigError, match="edge_width"):
        Effects(enabled=("stick_slip",), params={"stick_slip": {"edge_width": 1.5}})
    with pytest.raises(ConfigError, match="edge_width"):
        Effects(enabled=("stick_slip",), params={"stick_slip": {"edge_width": "wide"}})
    with pytest.raises(ConfigError, match="edge"):
        Effects(enabled=("stick_slip",), params={"stick_slip": {"edge": "round"}})
    assert EFFECT_OPTIONS["smooth_edge"] == ("stick_slip", "edge", "smooth")
