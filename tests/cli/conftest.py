"""Fixtures the command-line tests share."""

import pytest

from tendon_id.cli import main


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """A small posterior-6 recording with truth, simulated once per test module through the CLI."""
    path = tmp_path_factory.mktemp("data") / "p6.parquet"
    assert main(["simulate", "--protocol", "posterior-6", "--frames", "600", "--seed", "3", "--out", str(path)]) == 0
    return path
