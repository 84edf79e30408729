"""The identifiability page tells the truth: a misspecified fit's numbers are the fit's, advice only where checked."""

import dataclasses
import html
import re

import numpy as np
import pytest

from tendon_id.data import Recording
from tendon_id.identifiability.advice import CONFIRM_FRACTION, judge_advice
from tendon_id.identifiability.summary import lead_sentences
from tendon_id.identifiability.truth import data_name, truth_law
from tendon_id.report.identifiability import report_page, spectrum_figure


@pytest.fixture(scope="module")
def misspecified_html(misspecified):
    return html.unescape(report_page(misspecified).render())  # the text as the reader sees it


def _lead(html: str) -> str:
    return html.split('<section class="lead"', 1)[1].split("</section>", 1)[0]


# ---- a misspecified fit ---------------------------------------------------------------------------


def test_a_misspecified_fits_page_opens_with_the_warning_before_any_number(misspecified, misspecified_html):
    lead = _lead(misspecified_html)
    first = re.search(r'<p class="(\w+)">(.*?)</p>', lead, re.S)
    assert first.group(1) == "warning"
    warning = first.group(2)
    assert "not the robot" in warning
    # The warning's claim comes before the first digit of the lead, and the lead before the body.
    assert lead.index("does not explain this data") < re.search(r"\d", lead).start()
    assert misspecified_html.index("not the robot") < misspecified_html.index("<h2")
    # Before the first fitted number: the tied mu(0) = A + B of tendon 1, from the draws.
    d = misspecified.studies["tied"].draws[0]
    fitted = f"{np.mean(d[:, 0] + d[:, 1]):.3f}"
    assert misspecified_html.index("not the robot") < misspecified_html.index(fitted)


def test_the_truth_stands_beside_the_fitted_numbers(misspecified, paper_terminal_only, misspecified_html):
    law = paper_terminal_only.meta["friction_truth"]
    mu0 = [a + b for a, b in zip(law["A"], law["B"])]
    truth = next(s["text"] for s in lead_sentences(misspecified) if s["tone"] == "truth")
    assert ", ".join(f"{m:.2f}" for m in mu0) in truth and "misspecified fit gives" in truth
    for i, m in enumerate(mu0):
        said = rf"Tendon {i + 1}: fitted mu\(0\) = A \+ B = [-\d.]+ ± [\d.e-]+ \(truth {m:.2f}\)"
        assert re.search(said, misspecified_html)
    # Every estimate column of the profile table says whose it is.
    assert "fitted (misspecified) estimate" in misspecified_html


def test_the_profile_table_shows_the_informative_rows_and_folds_the_rest(misspecified, misspecified_html):
    section = misspecified_html.split('id="profile-likelihoods"', 1)[1]
    visible, folded = section.split("<details>", 1)
    per = [q for profs in misspecified.studies["per-guide"].profiles for q in profs]
    flat = sum(q.verdict == "structurally unidentifiable" for q in per)
    assert flat > 0 and "flat (structural)" not in visible
    assert f"{flat} of the per-guide law's {len(per)} profiles are structurally unidentifiable" in visible
    n_all = len(per) + sum(len(p) for p in misspecified.studies["tied"].profiles)
    assert folded.split("</details>")[0].count("<tr>") == n_all + 1  # and the header


def test_the_spectrum_is_labelled_in_its_units(study):
    # F = X^T W X / sigma^2 with X in rad, W in N^2 and sigma in N: dimensionless, per coefficient squared.
    fig = spectrum_figure(study)
    assert all(ax.get_ylabel() == "eigenvalue [-] (per friction coefficient²)" for ax in fig.axes)


# ---- the advice and its check ----------------------------------------------------------------------


def _candidates(expected: float) -> list[dict]:
    # Joint 2 is the linearised (D-optimal) advice; joint 3 the alternative.
    return [
        {"joint": 2, "log_det": 1.0, "expected_shrinkage": expected},
        {"joint": 3, "log_det": 0.0, "expected_shrinkage": expected / 3},
    ]


def test_the_check_confirms_the_advice_only_by_its_rule():
    expected, base = 0.6, {"band_width_mean": 10.0, "truth_coverage": 0.9, "rmse_n": 2.0}
    enough, short = 1.1 * CONFIRM_FRACTION * expected, 0.9 * CONFIRM_FRACTION * expected
    # The alternative narrows the band more than either: the check's best, whether or not the advice holds.
    alt = {"joint": 3, "measured_shrinkage": 0.8 * expected, "rmse_n": base["rmse_n"] / 2}
    ok = judge_advice(_candidates(expected), [{"joint": 2, "measured_shrinkage": enough, "rmse_n": 1.5}, alt], base)
    assert ok["status"] == "confirmed" and ok["recommended_joint"] == 2
    low = judge_advice(_candidates(expected), [{"joint": 2, "measured_shrinkage": short, "rmse_n": 1.5}, alt], base)
    assert low["status"] == "not confirmed" and low["recommended_joint"] is None
    assert low["measured_best_joint"] == ok["measured_best_joint"] == 3
    # Narrower, but further from the truth: not confirmed either.
    far = {"joint": 2, "measured_shrinkage": enough, "rmse_n": 2 * base["rmse_n"]}
    assert judge_advice(_candidates(expected), [far, alt], base)["status"] == "not confirmed"
    assert judge_advice(_candidates(expected), None, None)["status"] == "unchecked"


def test_the_advice_is_withheld_when_its_check_contradicts_it(study):
    js = study.to_dict()["advice"]
    advised = js["instrument_joint"]
    other = next(c["joint"] for c in js["check"] if c["joint"] != advised)
    # The advised joint's label leaves the band as wide as before, another joint's halves it, the rest
    # double it; none moves the estimate against the truth.
    base, rmse = study.studies["per-guide"].band.mean_width(), study.advice_baseline["rmse_n"]
    check = []
    for c in js["check"]:
        width = base if c["joint"] == advised else (base / 2 if c["joint"] == other else 2 * base)
        check.append({**c, "band_width_mean": width, "measured_shrinkage": 1 - width / base, "rmse_n": rmse})
    lead = lead_sentences(dataclasses.replace(study, advice_check=check))
    advice = lead[-1]
    assert advice["tone"] == "warning"
    assert advice["text"].startswith("No joint to instrument is advised")
    assert f"linearised advice (joint {advised}" in advice["text"] and "was not confirmed" in advice["text"]
    assert f"The check found joint {other} best: band 50 % narrower" in advice["text"]
    assert not any("Instrument joint" in s["text"] for s in lead)


def test_a_confirmed_advice_names_its_joint_with_both_figures(study):
    v = study.to_dict()["advice"]["verdict"]
    assert v["status"] == "confirmed"
    text = lead_sentences(study)[-1]["text"]
    assert text.startswith(f"Instrument joint {v['linearised_joint']} next")
    assert f"{round(100 * v['expected_shrinkage'])} % expected" in text
    assert f"{round(100 * v['measured_shrinkage'])} % narrower measured" in text


# ---- what the data is --------------------------------------------------------------------------------


def test_the_data_is_named_by_its_recipe_or_its_file(noise_only):
    assert data_name([noise_only]) == f"{noise_only.meta['recipe']}, terminal-only"
    real = noise_only.with_meta(recipe=None, friction_truth=None)
    assert data_name([real]) == "unnamed terminal-only data"
    named = Recording(real.frame, real.meta, source="/data/bench/run3.parquet")
    assert data_name([named]) == "run3.parquet"


def test_the_truth_law_is_read_from_the_recording_and_absent_from_real_data(noise_only):
    law = noise_only.meta["friction_truth"]
    out = truth_law([noise_only])
    assert out["mu0"] == pytest.approx([a + b for a, b in zip(law["A"], law["B"])])
    assert out["feasible"] == all(b >= abs(a) for a, b in zip(law["A"], law["B"]))
    assert truth_law([noise_only.with_meta(friction_truth=None)]) is None
