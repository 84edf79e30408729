"""Independent benchmark jobs through joblib: one checked runner, so Dask or Ray run them unchanged."""

from __future__ import annotations

import numpy as np
from joblib import Parallel

from tendon_id.errors import ConfigError


def job_runner(backend: str | None, n_jobs: int) -> Parallel:
    """A :class:`joblib.Parallel` yielding results as they finish.

    Parameters
    ----------
    backend : str or None
        joblib backend (``"loky"``, ``"threading"``, a registered ``"dask"`` / ``"ray"``...);
        None: the one :func:`joblib.parallel_config` sets.
    n_jobs : int
        Parallel jobs (joblib's meaning: -1 is all cores).

    Raises
    ------
    ConfigError
        For an ``n_jobs`` that is not a non-zero integer, or an unknown backend, before any job runs.
    """
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, (int, np.integer)) or n_jobs == 0:
        raise ConfigError(f"n_jobs must be a non-zero integer, got {n_jobs!r}")
    try:
        return Parallel(n_jobs=int(n_jobs), return_as="generator", **({"backend": backend} if backend else {}))
    except ValueError as exc:  # an unknown or unregistered backend name
        raise ConfigError(f"joblib backend {backend!r}: {exc}") from None
