import os

import pytest


@pytest.fixture(autouse=True)
def _isolated_cache(tmp_path_factory, monkeypatch):
    # Dataset builds go to a per-session folder, never the user's ~/.cache.
    monkeypatch.setenv("TENDON_ID_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))
    os.environ.setdefault("MPLBACKEND", "Agg")


# Property tests draw the same examples on every run, so CI results are reproducible.
from hypothesis import settings as _hyp_settings  # noqa: E402

_hyp_settings.register_profile("tendon-id", derandomize=True, deadline=None)
_hyp_settings.load_profile("tendon-id")
