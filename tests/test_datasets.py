import numpy as np
import pytest

import tendon_id.datasets as ds
from tendon_id.errors import ConfigError


def test_bundled_recipes_are_listed_and_load():
    assert "snake12-paper" in ds.names()
    r = ds.load_recipe("snake12-paper")
    assert r.robot.n_modules == 12 and r.friction.A == (0.30, 0.32, 0.28)
    assert r.effects.enabled == ("contact", "stick_slip", "viscoelastic", "per_tendon_wrap")


def test_load_builds_once_then_reads_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("TENDON_ID_CACHE", str(tmp_path))
    a = ds.load("snake12-paper", protocol="posterior-6", frames=300, seed=2)
    files = list(tmp_path.glob("*.parquet"))
    assert len(files) == 1 and files[0].name.startswith("snake12-paper-posterior-6-")
    stamp = files[0].stat().st_mtime_ns
    b = ds.load("snake12-paper", protocol="posterior-6", frames=300, seed=2)
    assert files[0].stat().st_mtime_ns == stamp  # read back, not rebuilt
    np.testing.assert_array_equal(a.terminal, b.terminal)
    assert a.meta == b.meta
    ds.load("snake12-paper", protocol="posterior-6", frames=300, seed=3)
    ds.load("snake12-paper", protocol="posterior-6", frames=300, seed=2, effects="none")
    assert len(list(tmp_path.glob("*.parquet"))) == 3  # each variant has its own entry


def test_unknown_recipe_names_the_known_ones():
    with pytest.raises(ConfigError, match="snake12-paper"):
        ds.load_recipe("snake13")


def test_a_recipe_file_by_path(tmp_path):
    p = tmp_path / "mini.toml"
    p.write_text(
        'name = "mini"\n[robot]\nn_modules = 4\n[protocols.planned-paths]\nframes = 200\ntrajectory_frames = 100\n'
    )
    rec = ds.load(p, protocol="planned-paths", cache=False)
    assert rec.n_modules == 4 and rec.n_frames == 200 and rec.meta["recipe"] == "mini"
