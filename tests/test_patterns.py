"""Patterns in mapping files (:mod:`tendon_id.data.patterns`): a few lines stand for every column."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tendon_id.data.mapping import load_mapping, read_files
from tendon_id.data.patterns import expand_columns, fill
from tendon_id.errors import ConfigError


def _log(n: int, m: int, rows: int = 4) -> pd.DataFrame:
    """A DAQ-style log of n modules with m tendons per set: its own names, degrees and mN."""
    rng = np.random.default_rng(n * 10 + m)
    cols = {"time_ms": 100.0 * np.arange(rows)}
    for k in range(1, n + 1):
        cols[f"enc{k}_pitch"] = rng.uniform(-5, 5, rows)
        cols[f"enc{k}_yaw"] = rng.uniform(-5, 5, rows)
    for j in range(1, n + 1):
        for i in range(1, m + 1):
            cols[f"cell_{j}_{i}"] = rng.uniform(5e4, 9e4, rows)
    for i in range(1, m + 1):
        cols[f"tip_{i}"] = rng.uniform(3e4, 5e4, rows)
    return pd.DataFrame(cols)


HEAD = 'kind = "snake"\n[meta]\nrobot = {{ n_modules = {n}, n_tendons = {m} }}\n[columns]\n'
TIME = 't = { column = "time_ms", unit = "ms" }\n'


def _patterned(n: int, m: int) -> str:
    return (
        HEAD.format(n=n, m=m)
        + TIME
        + (
            '"theta_{k}_x" = { column = "enc{k}_pitch", unit = "deg" }\n'
            '"theta_{k}_y" = { column = "enc{k}_yaw", unit = "deg" }\n'
            '"tension_act_{j}_{i}" = { column = "cell_{j}_{i}", unit = "mN" }\n'
            f'"tension_joint_{n}_{{i}}" = {{ column = "tip_{{i}}", unit = "mN" }}\n'
        )
    )


def _spelled_out(n: int, m: int) -> str:
    lines = [TIME]
    for k in range(1, n + 1):
        lines.append(f'theta_{k}_x = {{ column = "enc{k}_pitch", unit = "deg" }}\n')
        lines.append(f'theta_{k}_y = {{ column = "enc{k}_yaw", unit = "deg" }}\n')
    for j in range(1, n + 1):
        for i in range(1, m + 1):
            lines.append(f'tension_act_{j}_{i} = {{ column = "cell_{j}_{i}", unit = "mN" }}\n')
    for i in range(1, m + 1):
        lines.append(f'tension_joint_{n}_{i} = {{ column = "tip_{i}", unit = "mN" }}\n')
    return HEAD.format(n=n, m=m) + "".join(lines)


@settings(max_examples=12, deadline=None)
@given(n=st.integers(2, 12), m=st.integers(2, 5))
def test_a_pattern_reads_what_the_spelled_out_mapping_reads(tmp_path_factory, n, m):
    d = tmp_path_factory.mktemp("p")
    _log(n, m).to_csv(d / "run.csv", index=False)
    (d / "short.toml").write_text(_patterned(n, m))
    (d / "long.toml").write_text(_spelled_out(n, m))
    (a,) = read_files([d / "run.csv"], load_mapping(d / "short.toml"))
    (b,) = read_files([d / "run.csv"], load_mapping(d / "long.toml"))
    pd.testing.assert_frame_equal(a.frame, b.frame)
    assert a.n_tendons == m and a.actuator.shape == (4, n, m)
    np.testing.assert_allclose(a.actuator[0, 0, 0], _log(n, m)["cell_1_1"][0] * 1e-3, rtol=1e-15)


def test_placeholders_take_integer_arithmetic_and_nothing_else():
    assert fill("position[{2*k0 + 1}]", {"k0": 3}, "m") == "position[7]"
    assert fill("data[{3*j0 + i0}]", {"j0": 1, "i0": 2}, "m") == "data[5]"
    for bad in ("{__import__('os')}", "{k0 ** 2}", "{x}", "{k0 / 2}"):
        with pytest.raises(ConfigError, match="placeholder"):
            fill(bad, {"k0": 1}, "m.toml")


def test_an_explicit_key_overrides_its_pattern():
    cols = {"theta_{k}_x": {"column": "a{k}"}, "theta_2_x": {"column": "special"}}
    out = expand_columns(cols, 3, 3, "m.toml")
    assert out["theta_2_x"] == {"column": "special"}
    assert [out[f"theta_{k}_x"]["column"] for k in (1, 3)] == ["a1", "a3"]


def test_pattern_mistakes_name_the_pattern():
    with pytest.raises(ConfigError, match=r"columns\.theta_\{k\}_x.*how many"):
        expand_columns({"theta_{k}_x": "a{k}"}, None, 3, "m.toml")
    with pytest.raises(ConfigError, match="unknown placeholder name 'q'"):
        expand_columns({"theta_{q}_x": "a"}, 3, 3, "m.toml")
    with pytest.raises(ConfigError, match="both make"):
        expand_columns({"theta_{k}_x": "a{k}", "theta_{j}_x": "b{j}"}, 2, 3, "m.toml")


def test_every_command_that_reads_data_takes_a_mapping():
    import typer.main

    from tendon_id.cli.app import app

    group = typer.main.get_command(app)
    reading = []
    for name, command in group.commands.items():
        options = {o for p in command.params for o in getattr(p, "opts", [])}
        if "--data" in options or name == "info":
            reading.append(name)
            assert "--mapping" in options, f"tendon-id {name} reads data but takes no --mapping"
    assert {"fit", "evaluate", "calibrate", "identifiability", "diagnose", "convert", "info"} <= set(reading)
