"""The regime map: each regime is the recipe with one physical setting changed; the page draws what was measured."""

import numpy as np
import pytest

from tendon_id.benchmarks.regimes import GRID, Regime, format_regimes, grid_regimes, regimes
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError


@pytest.fixture(scope="module")
def paper():
    return load_recipe("snake12-paper")


@pytest.mark.parametrize("name, count", [("snake12-paper", 18), ("snake12-elastic", 16)])
def test_the_grid_changes_one_setting_at_a_time_in_both_sessions(name, count):
    base = load_recipe(name)
    cells = grid_regimes(base)
    assert len(cells) == count
    assert len({(c.setting, c.session) for c in cells}) == len(cells)
    own = base.effects.get("stick_slip")
    for c in cells:
        r = c.recipe(base)
        changed = [k for k in GRID if getattr(c, k) != getattr(Regime(), k)]
        assert len(changed) <= 1
        assert r.session == c.session
        assert r.effects.get("stick_slip").driver == (c.driver or own.driver)
        assert c.driver != own.driver  # the recipe's own driver is the recipe's regime
        assert r.effects.get("stick_slip").EA == pytest.approx(own.EA * c.ea_scale)
        assert c.ea_scale == 1.0 or own.driver == "elastic"  # the stiffness acts only on an elastic tendon
        assert r.effects.get("viscoelastic").kappa == pytest.approx(
            base.effects.get("viscoelastic").kappa * c.kappa_scale
        )
        assert c.kappa_scale == 1.0 or "viscoelastic" in base.effects
        assert ("per_tendon_wrap" in r.effects) == c.wraps
        np.testing.assert_allclose(r.friction.A, np.array(base.friction.A) * c.friction_scale)
        np.testing.assert_allclose(r.friction.B, np.array(base.friction.B) * c.friction_scale)
        # everything else is the recipe's
        assert r.robot == base.robot and r.sensors == base.sensors and r.actuation == base.actuation


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
