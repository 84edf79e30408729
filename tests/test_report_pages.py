"""The report pages: one Jinja2 layout, what the reader must know first, and sentences that match the numbers."""

from types import SimpleNamespace

import numpy as np
import pytest

from tendon_id.report.closed_loop_lead import lead_sentences as loop_lead
from tendon_id.report.comparison import surprises
from tendon_id.report.diagnosis_lead import lead_sentences as diagnosis_lead
from tendon_id.report.diagnosis_lead import percent
from tendon_id.report.html import HtmlPage
from tendon_id.report.truth import truth_sentence

META = {
    "recipe": "toy",
    "friction_truth": {"A": [0.3, 0.32, 0.28], "B": [0.09, 0.08, 0.1]},
    "effects": ["contact", "viscoelastic"],
    "session": "continuous",
}


def test_lead_comes_before_the_body_whatever_the_call_order():
    page = HtmlPage("T <1>", subtitle="sub")
    page.heading("Numbers")
    page.table(["a"], [[1.23456789]])
    page.lead("Read this first & trust it.", tone="warning")
    html = page.render()
    assert html.index("Read this first &amp; trust it.") < html.index("Numbers") < html.index("1.235")
    assert "T &lt;1&gt;" in html  # escaped by the template
    assert 'class="warning"' in html.split("Numbers")[0]


def test_page_is_self_contained():
    page = HtmlPage("t")
    page.lead("x", tone="verdict")
    page.table(["a"], [[1]], collapsed="all rows")
    html = page.render()
    assert "<script" not in html and "http://" not in html and "https://" not in html
    assert "<details><summary>all rows</summary>" in html


def test_a_lead_tone_outside_the_list_is_refused():
    with pytest.raises(ValueError, match="tone must be one of"):
        HtmlPage("t").lead("x", tone="loud")


def test_truth_sentence_states_the_law_effects_and_session_and_is_none_for_real_data():
    text = truth_sentence(META)
    # mu(0) = A + B per tendon: 0.39, 0.40, 0.38
    assert "0.39, 0.40, 0.38" in text and "viscoelastic lag" in text and "unlogged motion" in text
    assert truth_sentence({"recipe": "bench", "effects": []}) is None
    assert "unlogged" not in truth_sentence({**META, "session": "fresh"})


def _diag(named, kind, best, at_bound=(), truth=META):
    cand = SimpleNamespace(effect=best, gap_closed=0.69, at_bound=tuple(at_bound), params={"offset": 1, "gain": 0})
    other = SimpleNamespace(effect="viscoelastic", gap_closed=0.004, at_bound=(), params={})
    return SimpleNamespace(
        unit="N",
        base="capstan",
        base_rmse=50.0,
        noise_floor=1.6,
        validation="held-out test data",
        verdict=SimpleNamespace(kind=kind, effects=list(named), text=f"{kind} text"),
        candidates=[cand, other],
        truth=truth,
        skipped={"contact": "already in the base"},
    )


def test_diagnosis_lead_says_a_verdict_outside_the_truth_is_wrong():
    lead = diagnosis_lead(_diag(["sensor_bias"], "explained", "sensor_bias"))
    assert lead[0][1] == "verdict"
    text = " ".join(t for t, _ in lead)
    assert "verdict is wrong" in text and "load-cell bias is not in the truth" in text


def test_diagnosis_lead_says_a_verdict_inside_the_truth_is_right():
    text = " ".join(t for t, _ in diagnosis_lead(_diag(["viscoelastic"], "explained", "viscoelastic")))
    assert "verdict is right" in text


def test_diagnosis_lead_warns_of_a_candidate_at_its_bounds_and_names_what_was_missed():
    lead = diagnosis_lead(_diag([], "unexplained", "sensor_bias", at_bound=("offset", "gain")))
    tones = [tone for _, tone in lead]
    assert tones[:3] == ["verdict", "warning", "truth"]
    assert "every parameter" in lead[1][0]
    assert "viscoelastic lag" in lead[-1][0] and "0% for viscoelastic" in lead[-1][0]
    assert "start state" in lead[-1][0]


def test_diagnosis_lead_on_real_data_says_no_truth_is_known():
    text = " ".join(t for t, _ in diagnosis_lead(_diag([], "unexplained", "sensor_bias", truth=None)))
    assert "real data" in text and "truth (" not in text


def test_percent_never_shows_minus_zero():
    assert percent(-0.003) == "0%" and percent(0.694) == "69%" and percent(-0.012) == "-1%"


def _score(rmse, r2):
    return {"terminal": {"rmse": rmse, "r2": r2}, "joints": None}


def test_surprises_explain_a_negative_r2_and_a_baseline_that_wins():
    rng = np.random.default_rng(0)
    test = {"p6": SimpleNamespace(terminal=150 + 2.0 * rng.standard_normal((500, 3)))}
    scores = {"p6": {"base": _score(28.8, -7.09), "net": _score(38.0, -12.0)}}
    out = surprises(scores, test, learned={"net"})
    assert "R2 below 0" in out[0] and "-12.00 for net" in out[0]
    sd = np.mean(np.std(test["p6"].terminal, axis=0))
    assert f"= {1 - (38.0 / sd) ** 2:.1f}." in out[0]  # R^2 = 1 - RMSE^2 / variance
    # the sd quoted is the held-out terminal tension's own
    assert f"{np.mean(np.std(test['p6'].terminal, axis=0)):.1f} N" in out[0]
    assert "base beats net" in out[1] and "28.8 N against 38.0 N" in out[1]
    assert surprises({"p6": {"base": _score(40.0, 0.5), "net": _score(30.0, 0.7)}}, test, {"net"}) == []


def _row(est, loop, settle, torque, rms=0.3):
    return {
        "regime": "p3",
        "estimator": est,
        "loop": loop,
        "settle_s": settle,
        "rms_deg": rms,
        "seeds": 1,
        "why": {"torque_error_nm": torque},
    }


def test_closed_loop_lead_ranks_by_settling_and_explains_the_slowest():
    rows = [_row("oracle", k, 1.5, 0.02) for k in (1, 2)]
    rows += [_row("a", 1, 4.0, 0.3), _row("a", 2, 5.0, 0.3), _row("b", 1, 9.0, 0.9), _row("b", 2, None, 0.9)]
    lead = loop_lead({"rows": rows}, open_loop={"a": 20.0, "b": 10.0})
    assert (
        "a settles fastest (4.5 s" in lead[0][0]
        and "b settles slowest (it does not settle within the test in 1 of its 2 runs" in lead[0][0]
    )
    assert "0.90 N m" in lead[1][0] and "most accurate open loop" in lead[1][0]
    assert "one seed" in lead[-1][0]


def test_closed_loop_lead_warns_first_when_the_oracle_itself_does_not_settle():
    rows = [_row("oracle", 1, None, 0.02), _row("oracle", 2, 3.0, 0.02)]
    rows += [_row("a", 1, 4.0, 0.3), _row("a", 2, 5.0, 0.3), _row("b", 1, 9.0, 0.9), _row("b", 2, 8.0, 0.9)]
    lead = loop_lead({"rows": rows})
    assert lead[0][1] == "warning" and "even the true tensions (oracle) do not settle" in lead[0][0]
    assert lead[1][1] == "verdict" and "a settles fastest" in lead[1][0]
    settled = [_row("oracle", k, 1.5, 0.02) for k in (1, 2)] + rows[2:]
    assert all(tone != "warning" for _, tone in loop_lead({"rows": settled}))


def test_closed_loop_lead_ranks_by_rms_when_no_estimator_settles():
    """A loop that never settles is not "fastest": with none settled everywhere, the RMS error ranks them."""
    rows = [_row("oracle", k, 1.5, 0.02, rms=0.3) for k in (1, 2)]
    rows += [_row("a", 1, None, 0.3, rms=1.4), _row("a", 2, None, 0.3, rms=1.2)]
    rows += [_row("b", 1, 6.0, 0.5, rms=0.7), _row("b", 2, None, 0.5, rms=1.1)]
    verdict = loop_lead({"rows": rows})[0][0]
    assert "no estimator settles in every loop; b tracks best (RMS 0.90°), a worst (1.30°)" in verdict
    assert "against 0.30° with the true tensions" in verdict and "fastest" not in verdict


def _rec(angle_deg, tension):
    """A 12-module recording stand-in: every joint bent by ``angle_deg``, every actuator at ``tension`` [N]."""
    t = len(tension)
    angles = np.full((t, 12, 2), np.deg2rad(angle_deg) / np.sqrt(2))
    return SimpleNamespace(
        n_modules=12, meta={}, angles=angles, actuator=np.repeat(tension[:, None, None], 12, 1) * [1, 1, 1]
    )


def test_a_baseline_win_is_called_extrapolation_only_where_the_test_leaves_the_training_range():
    train = _rec(5.0, np.linspace(80, 200, 50))
    inside = _rec(4.0, np.linspace(90, 190, 50))
    beyond = _rec(4.0, np.linspace(90, 300, 50))
    scores = {"p6": {"base": _score(28.8, 0.1), "net": _score(38.0, 0.1)}}
    said = surprises(scores, {"p6": inside}, {"net"}, train)[0]
    assert "not extrapolation" in said
    said = surprises(scores, {"p6": beyond}, {"net"}, train)[0]
    # 90 + 210 k / 49 exceeds the training's 200 N for k >= 26: 24 of the 50 frames
    assert "extrapolates" in said and "48% pull harder" in said and "0% of its frames bend" in said


def test_closed_loop_lead_explains_a_slow_single_loop_of_the_open_loop_best():
    # The demo's posterior-3 run: pg-chtc-ns settles worst on the step (10.5 s) but not worst on average.
    rows = [_row("cn", 1, 8.2, 1.081), _row("cn", 2, 8.3, 0.820)]
    rows += [_row("pg", 1, 4.8, 0.581), _row("pg", 2, 2.3, 0.516)]
    rows += [_row("ns", 1, 10.5, 0.561), _row("ns", 2, 3.7, 0.593)]
    for r in rows:
        r["rms_deg"] = 0.42
    lead = loop_lead({"rows": rows}, open_loop={"cn": 32.1, "pg": 29.5, "ns": 22.6})
    text = " ".join(t for t, _ in lead)
    assert "cn settles slowest (8.2 s)" in text
    assert "ns has the slowest single settling, 10.5 s on the step" in text
    # its torque error on the step (0.561) is no larger than pg's (0.581): the estimate does not explain it
    assert "no larger than pg's (0.58 N m)" in text and "most accurate open loop (22.6 N" in text


def test_the_truth_names_its_options_and_the_inherited_start_state():
    from tendon_id.report.truth import truth_names

    meta = {"effects": ["contact", "stick_slip"], "options": ["elastic_tendon"], "session": "continuous"}
    assert truth_names(meta) == {"contact", "stick_slip", "elastic_tendon", "start_state"}
    assert "start_state" not in truth_names({**meta, "session": "fresh"})
    assert "start_state" not in truth_names({"effects": ["contact"], "session": "continuous"})  # nothing stateful
    assert truth_names(None) == set()
