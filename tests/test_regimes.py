"""The regime map: each regime is the recipe with one physical setting changed; the page draws what was measured."""

import numpy as np
import pytest

from tendon_id.benchmarks.regimes import GRID, SESSIONS, Regime, format_regimes, grid_regimes, regimes
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError


@pytest.fixture(scope="module")
def paper():
    return load_recipe("snake12-paper")


def test_the_grid_changes_one_setting_at_a_time_in_both_sessions(paper):
    cells = grid_regimes()
    per_session = 1 + sum(len(v) - 1 for v in GRID.values())
    assert len(cells) == per_session * len(SESSIONS) == 16
    assert len({(c.setting, c.session) for c in cells}) == len(cells)
    for c in cells:
        r = c.recipe(paper)
        changed = [k for k in GRID if getattr(c, k) != getattr(Regime(), k)]
        assert len(changed) <= 1
        assert r.session == c.session
        assert r.effects.get("stick_slip").driver == c.driver
        assert r.effects.get("viscoelastic").kappa == pytest.approx(
            paper.effects.get("viscoelastic").kappa * c.kappa_scale
        )
        assert ("per_tendon_wrap" in r.effects) == c.wraps
        np.testing.assert_allclose(r.friction.A, np.array(paper.friction.A) * c.friction_scale)
        np.testing.assert_allclose(r.friction.B, np.array(paper.friction.B) * c.friction_scale)
        # everything else is the recipe's
        assert r.robot == paper.robot and r.sensors == paper.sensors and r.actuation == paper.actuation


def test_bad_settings_fail_before_any_job(paper):
    with pytest.raises(ConfigError, match="no recipe named"):
        regimes(recipe="no-such-recipe")
    with pytest.raises(ConfigError, match="n_jobs"):
        regimes(n_jobs=0)


@pytest.mark.slow
def test_one_regime_end_to_end_with_the_page(tmp_path):
    from tendon_id.report.regimes import write_regimes_page

    res = regimes(preset="tiny", only=[Regime(session="fresh")])
    names = {r["method"] for r in res["rows"]}
    assert names == {"capstan-nonsmooth", "pg-chtc", "pg-chtc-ns"}
    base = next(r for r in res["rows"] if r["method"] == "capstan-nonsmooth")
    assert base["ratio_terminal"] == 1.0
    assert 0.5 < base["floor_rmse"] < 2.0  # the recipe's 1 N load cells
    assert "recipe, fresh" in format_regimes(res)
    page = write_regimes_page(res, tmp_path / "regimes.html").read_text()
    assert "data:image/png;base64," in page and "best at the terminal" in page
