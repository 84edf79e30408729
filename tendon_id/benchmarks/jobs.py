"""Independent benchmark jobs through joblib: one checked runner, so Dask or Ray run them unchanged."""

from __future__ import annotations

from joblib import Parallel

from tendon_id.checks import check_jobs
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
    n_jobs = check_jobs("n_jobs", n_jobs)
    try:
        return Parallel(n_jobs=n_jobs, return_as="generator", **({"backend": backend} if backend else {}))
    except ValueError as exc:  # an unknown or unregistered backend name
        raise ConfigError(f"joblib backend {backend!r}: {exc}") from None
