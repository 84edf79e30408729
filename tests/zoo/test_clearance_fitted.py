"""The clearance and the routing wrap are fitted: no model reads them from a recording's metadata."""

import dataclasses
import json

import numpy as np
import pytest

from friction_models import dead_zone_wrap
from tendon_id import zoo
from tendon_id.data import Recording
from tendon_id.datasets import load_recipe
from tendon_id.geometry import RobotGeometry, backbone_wrap
from tendon_id.report.calibration import run_calibration
from tendon_id.sim import simulate
from tendon_id.zoo.blocks.geometric import CLEARANCE_START, clearance_start
from tendon_id.zoo.features import padded_unit_inputs

RECIPE = load_recipe("snake12-noise-only")  # a feasible law (B >= |A|), the robot of snake12-paper
TRUE_A0, TRUE_AC = RECIPE.robot.alpha_0, RECIPE.robot.alpha_c  # 0.05 and 0.08 rad


@pytest.fixture(scope="module")
def recording():
    return simulate(RECIPE, "planned-paths", effects="contact,stick_slip", frames=600, seed=2).recording


def planted(rec: Recording) -> Recording:
    """``rec`` with a wrong clearance and routing wrap in its robot metadata."""
    return rec.with_meta(robot={**rec.meta["robot"], "alpha_0": 0.2, "alpha_c": 0.01})


MODELS = {
    "capstan-simple": {},
    "capstan-contact": {},
    "hard-gate": {"name": "capstan", "blocks": (zoo.ContactGate(gate="hard"),)},
    "capstan-nonsmooth": {"n_starts": 1, "maxeval": 60},
    "exact-wrap": {"name": "capstan", "blocks": ("contact", zoo.PerTendonWrap(model="exact"))},
    "projected-wrap": {"name": "capstan", "blocks": ("contact", zoo.PerTendonWrap(model="projected")), "maxeval": 40},
}


@pytest.mark.parametrize("label", MODELS)
def test_a_wrong_clearance_in_the_metadata_changes_no_fit(recording, label):
    settings = dict(MODELS[label])
    name = settings.pop("name", label)
    a = zoo.make(name, **settings).fit(recording)
    b = zoo.make(name, **settings).fit(planted(recording))
    assert b.geometry_.alpha_c == 0.01  # it was read into the robot, and not used
    np.testing.assert_array_equal(a.A_, b.A_)
    np.testing.assert_array_equal(a.B_, b.B_)
    assert a.block_values_ == b.block_values_
    assert set(a.block_values_["routing"]) == {"alpha_0"}  # every capstan model fits its routing wrap
    np.testing.assert_array_equal(a.predict_chain(recording), b.predict_chain(planted(recording)))


def test_the_learned_models_take_the_routing_wrap_from_their_prior(recording):
    a = zoo.make("pg-chtc-ns", correction=False, progress=False).fit(recording)
    b = zoo.make("pg-chtc-ns", correction=False, progress=False).fit(planted(recording))
    assert a.alpha_0_ == b.alpha_0_ == a.prior_model_.alpha_0_
    np.testing.assert_array_equal(a.predict(recording), b.predict(planted(recording)))
    # The unit inputs of the cascades read the wrap with the alpha_0 they are given, never the robot's.
    pieces = [(0, 50)]
    x = padded_unit_inputs(a.prior_model_.inputs(recording), pieces, a.alpha_0_)
    y = padded_unit_inputs(a.prior_model_.inputs(planted(recording)), pieces, a.alpha_0_)
    np.testing.assert_array_equal(x["alpha"], y["alpha"])
    given = zoo.make("pg-chtc", prior={"A": [0.1] * 3, "B": [0.2] * 3}, progress=False)
    assert given.alpha_0_ == 0.0  # no prior yet: no routing wrap


def dead_zone_truth(gate: str, noise_n: float = 0.5, seed: int = 0) -> Recording:
    """A recording whose terminal label is the capstan with the clearance's ``gate``, computed here.

    The simulator gives the motion and the actuator-side tensions (no effect on); the label is
    ``T[1, N] exp(-sum_k mu(alpha_k) alpha_eff_k)`` with the backbone wrap of the robot's routing
    wrap, independent of the zoo's chain.
    """
    rec = simulate(RECIPE, "posterior-3", effects="none", frames=2000, seed=3).recording
    alpha = backbone_wrap(rec.angles, TRUE_A0)  # (T, K)
    A, B = np.array(RECIPE.friction.A), np.array(RECIPE.friction.B)
    mu = A * np.cos(alpha)[..., None] + B  # (T, K, 3)
    effective = dead_zone_wrap(alpha, TRUE_AC) if gate == "dead_zone" else alpha * (alpha > TRUE_AC)
    label = rec.actuator[:, -1] * np.exp(-np.sum(mu * effective[..., None], axis=1))
    label = label + np.random.default_rng(seed).normal(0.0, noise_n, label.shape)
    return Recording.from_arrays(
        trajectory=rec.trajectory_ids,
        t=rec.time,
        angles=rec.angles,
        actuator=rec.actuator,
        terminal=label,
        joint_truth=None,
        meta=rec.meta,
    )


@pytest.mark.parametrize("gate", ["dead_zone", "hard"])
def test_the_clearance_and_the_routing_wrap_are_recovered(gate):
    # 2000 frames of posterior-3 (wraps of 3-14 deg), 0.5 N load-cell noise: both within 0.005 rad
    # (measured: under 0.002 rad), from starts of 0.0997 and 0 rad.
    rec = dead_zone_truth(gate)
    m = zoo.make("capstan", blocks=(zoo.ContactGate(gate=gate),)).fit(rec)
    assert m.alpha_c_ == pytest.approx(TRUE_AC, abs=0.005)
    assert m.alpha_0_ == pytest.approx(TRUE_A0, abs=0.005)
    np.testing.assert_allclose(m.mu0_[0], np.add(RECIPE.friction.A, RECIPE.friction.B), rtol=0.01)
    # A user who knows the routing wrap holds it; the clearance is then recovered as closely.
    known = zoo.RoutingWrap(alpha_0=TRUE_A0, fixed=True)
    held = zoo.make("capstan", blocks=(known, zoo.ContactGate(gate=gate))).fit(rec)
    assert held.alpha_c_ == pytest.approx(TRUE_AC, abs=0.005)
    assert "routing" not in held.block_values_


def test_the_simulators_dead_zone_is_recovered():
    # The simulator's own contact (snake12-noise-only: contact.gate = "dead_zone"), 1 N noise, 1500 frames.
    assert RECIPE.effects.get("contact").gate == "dead_zone"
    rec = simulate(RECIPE, "posterior-3", effects="contact", frames=1500, seed=4).recording
    m = zoo.make("capstan-contact").fit(rec)
    assert m.alpha_c_ == pytest.approx(TRUE_AC, abs=0.005)
    assert m.alpha_c_ - m.alpha_0_ == pytest.approx(TRUE_AC - TRUE_A0, abs=0.003)


def test_the_clearance_starts_from_what_the_user_measured():
    measured = RobotGeometry(hole_diameter=1.3e-3, tendon_diameter=1.0e-3, hole_length=3.0e-3, alpha_c=0.2)
    assert clearance_start(measured) == pytest.approx(np.arctan(0.3 / 3.0))
    assert clearance_start(RobotGeometry(alpha_c=0.2)) == CLEARANCE_START  # the truth is never the start
    assert zoo.ContactGate().started_from(measured).alpha_c == pytest.approx(np.arctan(0.1))
    assert zoo.ContactGate(alpha_c=0.05).started_from(measured).alpha_c == 0.05  # a given start is kept


def test_save_load_and_calibration_json_carry_the_fitted_geometry(recording, tmp_path):
    m = zoo.make("capstan-contact").fit(recording)
    back = zoo.load(m.save(tmp_path / "m"))
    assert (back.alpha_0_, back.alpha_c_) == (m.alpha_0_, m.alpha_c_)
    assert back.block_values_ == m.block_values_
    np.testing.assert_array_equal(back.predict_chain(recording), m.predict_chain(recording))
    saved = json.loads((tmp_path / "m" / "model.json").read_text())
    assert saved["state"]["block_values"]["contact"]["alpha_c"] == m.alpha_c_
    run_calibration([recording], model="capstan-contact", out=tmp_path / "cal")
    doc = json.loads((tmp_path / "cal" / "calibration.json").read_text())
    assert {"model", "tying", "A", "B", "mu0", "terminal"} <= set(doc)  # the keys it always had
    assert doc["alpha_0"] == pytest.approx(m.alpha_0_) and doc["alpha_c"] == pytest.approx(m.alpha_c_)


def test_a_model_saved_before_the_geometry_was_fitted_predicts_as_it_did(recording, tmp_path):
    # Such a file has no routing block and a contact block without alpha_c: it ran with its robot's
    # angles and the hard gate, which it keeps, held.
    m = zoo.make("capstan-contact").fit(recording)
    folder = m.save(tmp_path / "old")
    doc = json.loads((folder / "model.json").read_text())
    doc["params"]["blocks"] = [{"block": "contact", "fixed": False}]
    doc["state"]["block_values"] = {}
    (folder / "model.json").write_text(json.dumps(doc))
    old = zoo.load(folder)
    geo = m.geometry_
    assert (old.alpha_0_, old.alpha_c_) == (geo.alpha_0, geo.alpha_c)
    same = zoo.make("capstan", blocks=(zoo.ContactGate(alpha_c=geo.alpha_c, gate="hard", fixed=True),))
    same.blocks += (zoo.RoutingWrap(alpha_0=geo.alpha_0, fixed=True),)
    same = same.fitted_with(m.A_, m.B_, geo, m.n_modules_)
    np.testing.assert_array_equal(old.predict(recording), same.predict(recording))


def test_dataclass_replace_keeps_a_block_a_block():
    gate = dataclasses.replace(zoo.ContactGate(), alpha_c=0.1, fixed=True)
    assert gate.initial() == {"alpha_c": 0.1} and gate.settings() == {"gate": "dead_zone"}
    with pytest.raises(Exception, match="gate"):
        zoo.ContactGate(gate="soft")


@pytest.mark.parametrize("phi_shape", [(50, 11, 1, 1), (50, 11, 1, 3), (1,)], ids=["same", "wider", "scalar-like"])
def test_the_dead_zone_gate_is_computed_in_place_with_the_former_bits(phi_shape):
    """The gate's share made in its own array (issue 42) is divide(dead zone, alpha, where alpha > 0) times phi."""
    from tendon_id.zoo.blocks.base import HookContext

    rng = np.random.default_rng(4)
    alpha = rng.uniform(0.0, 0.4, (50, 11, 1, 1))
    alpha[::7] = 0.0  # no wrap: no share, not 0/0
    phi = rng.uniform(0.5, 2.0, phi_shape)
    ctx = HookContext(None, np.array([11]), np.arange(3), alpha=alpha)
    got = zoo.ContactGate(gate="dead_zone").exponent(phi.copy(), ctx, {"alpha_c": 0.08})
    want = phi * np.divide(dead_zone_wrap(alpha, 0.08), alpha, out=np.zeros(alpha.shape), where=alpha > 0)
    assert got.shape == want.shape
    np.testing.assert_array_equal(got, want)
