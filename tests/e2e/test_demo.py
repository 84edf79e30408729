"""End to end: the demo builds the default recipe and writes a self-contained summary page."""

import dataclasses
import html
import re

import pytest

from tendon_id.cli import main
from tendon_id.datasets import DEFAULT_RECIPE


def test_demo_writes_a_self_contained_summary(tmp_path, capsys):
    code = main(["demo", "--out", str(tmp_path / "out"), "--frames", "600", "--no-models"])
    assert code == 0, capsys.readouterr().err
    page = (tmp_path / "out" / "summary.html").read_text()
    assert page.startswith("<!DOCTYPE html>")
    # Every figure is embedded (no external files): wrap coverage, and per protocol a trace and a scatter.
    images = re.findall(r'<img alt="[^"]*" src="data:image/png;base64,[A-Za-z0-9+/=]+"', page)
    assert len(images) == 1 + 2 * 4
    for name in ("terminal-only", "posterior-3", "posterior-6", "planned-paths"):
        assert name in page
    assert "http://" not in page and "https://" not in page
    # without models, the first screen says so and states the simulator's truth
    lead = html.unescape(page.split('class="lead"')[1].split("</section>")[0])
    assert "no model was trained" in lead and f"The simulator's truth ({DEFAULT_RECIPE})" in lead
    # the default recipe's physics, in words: elastic tendons and the clearance's dead zone
    assert "elastic tendons through capstan stick–slip bands" in lead and "dead zone" in lead


@pytest.mark.slow  # 314 s of one CI worker in the durations run at d67b1f4; `make test-all` runs it
def test_demo_with_models_compares_capstan_and_pgchtc(tmp_path, capsys, monkeypatch):
    # The full demo trains PG-CHTC (fast preset); here the tiny preset keeps the test short.
    import tendon_id.zoo as zoo

    real_make = zoo.make

    def small(name, **kw):
        if name in ("pg-chtc", "pg-chtc-ns"):
            kw["preset"] = "tiny"
        return real_make(name, **kw)

    monkeypatch.setattr(zoo, "make", small)
    # and a shorter step test (each loop held 3 s, not 12 s): the page is the same shape, at a quarter of the time
    import tendon_id.benchmarks.table3 as table3

    real_step = table3.step_test
    monkeypatch.setattr(table3, "step_test", lambda *a: dataclasses.replace(real_step(*a), hold_s=3.0, lead_s=0.5))
    # and the identifiability study at the sampler sizes of its own tests (the defaults take a minute)
    import tendon_id.identifiability as identifiability

    real_analyse = identifiability.analyse
    small = identifiability.StudySettings(n_chains=32, n_steps=300, thin=10, band_frames=400)
    monkeypatch.setattr(identifiability, "analyse", lambda rec, **kw: real_analyse(rec, small, **kw))
    code = main(["demo", "--out", str(tmp_path / "out"), "--frames", "400"])
    assert code == 0, capsys.readouterr().err
    page = (tmp_path / "out" / "summary.html").read_text()
    assert "PG-CHTC" in page and "capstan-nonsmooth" in page and "intermediate joints RMSE" in page
    assert "PG-CHTC-NS" in page
    # the closed loop's page (Fig. 6), linked from the summary
    assert 'href="closed_loop.html"' in page
    loop = (tmp_path / "out" / "closed_loop.html").read_text()
    assert "pg-chtc" in loop and "oracle" in loop and 'src="data:image/png;base64,' in loop
    # each learned cascade's guard: its validation RMSE against its calibrated prior's
    assert page.count("for its calibrated prior capstan-nonsmooth") == 2
    assert len(re.findall(r'src="data:image/png;base64,', page)) == 1 + 2 * 4 + 2
    # the result first: the verdict and the truth in the lead, then the comparison, and the data last
    lead = html.unescape(page.split('class="lead"')[1].split("</section>")[0])
    assert "estimates the unmeasured intermediate joint-side tensions best" in lead and "simulator's truth" in lead
    assert page.index("Result: the estimators") < page.index("Sim-to-real gap") < page.index("The simulated data")
    assert "Its verdict:" in page  # the diagnosis's finding, beside its link
    for name in ("diagnosis", "closed_loop"):
        other = (tmp_path / "out" / f"{name}.html").read_text()
        assert 'class="lead"' in other.split("<h2")[0], name  # each page opens with what to know
