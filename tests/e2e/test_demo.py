"""End to end: the demo builds the default recipe and writes a self-contained summary page."""

import re

from tendon_id.cli import main


def test_demo_writes_a_self_contained_summary(tmp_path, capsys):
    code = main(["demo", "--out", str(tmp_path / "out"), "--frames", "600"])
    assert code == 0, capsys.readouterr().err
    page = (tmp_path / "out" / "summary.html").read_text()
    assert page.startswith("<!DOCTYPE html>")
    # Every figure is embedded (no external files): wrap coverage, and per protocol a trace and a scatter.
    images = re.findall(r'<img alt="[^"]*" src="data:image/png;base64,[A-Za-z0-9+/=]+"', page)
    assert len(images) == 1 + 2 * 4
    for name in ("terminal-only", "posterior-3", "posterior-6", "planned-paths"):
        assert name in page
    assert "http://" not in page and "https://" not in page
