"""The withheld-effect benchmark: its cases, its summary, and its jobs on a Dask cluster."""

import numpy as np
import pytest

from tendon_id.benchmarks.diagnosis import benchmark_cases, run_cases, summarise
from tendon_id.benchmarks.withheld import LIBRARY, OTHER_FORMS, Case, case_recipe


def test_quick_and_full_cases_cover_every_kind():
    quick = benchmark_cases(quick=True)
    assert {c.truth[0] for c in quick if c.kind == "single"} == set(LIBRARY)  # every effect, and the smooth edge
    assert {c.kind for c in quick} == {"single", "null", "out-of-library", "other-form", "pair"}
    full = benchmark_cases()
    assert {c.truth[0] for c in full if c.kind == "other-form"} == set(OTHER_FORMS)
    assert len(OTHER_FORMS) >= 3  # at least three families in a form their block does not take
    singles = [c for c in full if c.kind == "single"]
    assert len({c.seed for c in singles}) >= 5
    assert {c.magnitude for c in singles} == {"half", "default", "double"}
    assert len([c for c in full if c.kind == "null"]) >= 5


def test_case_truth_is_the_base_structure_plus_the_withheld_effect():
    c = Case("single", ("viscoelastic",), "double", 0, 100)
    recipe = case_recipe(c)
    assert c.base == "capstan-nonsmooth" and recipe.session == "fresh"
    assert recipe.effects.enabled == ("contact", "stick_slip", "viscoelastic")
    assert recipe.effects.get("viscoelastic").kappa == pytest.approx(0.08)  # twice the default 0.04
    assert case_recipe(Case("single", ("contact",), "half", 0, 100)).effects.enabled == ("contact",)
    assert case_recipe(Case("null", (), "default", 0, 100)).effects.enabled == ("contact", "stick_slip")


def test_each_new_case_kind_simulates_what_it_says():
    # the start state: the logs are cut from one session
    assert case_recipe(Case("single", ("start_state",), "default", 0, 100)).session == "continuous"
    # the elastic tendon: an option of stick_slip, at twice the default stiffness
    r = case_recipe(Case("single", ("elastic_tendon",), "double", 0, 100))
    assert r.effects.get("stick_slip").driver == "elastic" and r.effects.get("stick_slip").EA == pytest.approx(7e4)
    # actuator cells: drawn once per case, the same in the training and the test runs
    c = Case("single", ("actuator_cells",), "default", 3, 100)
    assert case_recipe(c).effects.get("actuator_cells").gain == case_recipe(c).effects.get("actuator_cells").gain
    assert np.std(case_recipe(c).effects.get("actuator_cells").gain) > 0
    # a drift runs in over the case's session as the simulator's default does over a paper-sized one
    for c in (
        Case("single", ("friction_drift",), "double", 0, 1000),
        Case("other-form", ("friction_drift~hyperbolic",), "default", 0, 2000),
    ):
        drift = case_recipe(c).effects.get("friction_drift")
        assert drift.run_in_length_m == pytest.approx(0.5 * c.frames / 10000)
    assert (
        case_recipe(Case("single", ("friction_drift",), "double", 0, 1000)).effects.get("friction_drift").run_in_drop
        == 0.4
    )
    # other forms switch their family on in the other form
    forms = {
        "sensor_bias~warm_up": ("sensor_bias", "drift_form", "warm_up"),
        "load_cell_dynamics~second_order": ("load_cell_dynamics", "order", 2),
        "friction_drift~hyperbolic": ("friction_drift", "form", "hyperbolic"),
    }
    for name, (effect, setting, value) in forms.items():
        r = case_recipe(Case("other-form", (name,), "default", 0, 100))
        assert effect in r.effects.enabled and getattr(r.effects.get(effect), setting) == value, name
        assert Case("other-form", (name,), "default", 0, 100).library == ()  # no oracle refit: no block has it


def _row(kind, truth, label, ladder=(), mag="default", base=10.0, final=2.0, oracle=None):
    return {
        "kind": kind,
        "truth": list(truth),
        "label": label,
        "magnitude": mag,
        "ladder": list(ladder),
        "base_rmse": base,
        "ladder_rmse": final,
        "oracle_rmse": oracle,
    }


def test_summary_counts_by_hand():
    rows = [
        _row("single", ["viscoelastic"], "viscoelastic", oracle=2.0),  # shrinkage 8 of 8: error 0
        _row("single", ["viscoelastic"], "sensor_bias", oracle=6.0) | {"rivals": ["viscoelastic"]},  # error 1
        _row("single", ["contact"], "contact", mag="half", oracle=1.0),  # 8 against 9: error 1/9
        _row("null", [], "none"),
        _row("null", [], "unexplained"),
        _row("out-of-library", ["sensor_delay"], "viscoelastic"),
        _row("out-of-library", ["sensor_delay"], "unexplained"),
        _row("pair", ["viscoelastic", "sensor_bias"], "viscoelastic", ladder=["viscoelastic", "sensor_bias"]),
    ]
    s = summarise(rows)
    assert s["top1"] == {"half": 1.0, "default": 0.5}
    assert s["top1_or_rival"] == {"half": 1.0, "default": 1.0}  # the truth as the named effect's rival counts
    assert s["null_false_alarm"] == 0.5
    assert s["ool_named"] == 0.5
    assert s["pair_recovered"] == 1.0
    assert s["median_shrinkage_error"] == pytest.approx(1 / 9)
    assert s["confusion"]["viscoelastic"]["sensor_bias"] == 1 and s["confusion"]["none"]["unexplained"] == 1


def test_cases_run_unchanged_on_a_dask_cluster():
    distributed = pytest.importorskip("distributed")
    # One case: what is tested is that a job crosses to a worker process and back unchanged (the
    # cases' own figures are the other tests'); a second case doubled the test's minutes in CI.
    cases = [Case("single", ("sensor_bias",), "default", 0, 320)]
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster):
            rows = run_cases(cases, backend="dask")
    assert [r["kind"] for r in rows] == ["single"]
    again = run_cases(cases)  # joblib's default backend, in this process

    def strip(rs):
        return [{k: v for k, v in r.items() if k != "seconds"} for r in rs]

    assert strip(rows) == strip(again)  # the same numbers, wherever the jobs ran
