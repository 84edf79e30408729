"""Benchmarks that reproduce the paper's tables on simulated data (``tendon-id benchmark NAME``).

Each benchmark returns the JSON object of :doc:`/cli`:
``{"benchmark", "preset", "rows": [{"method", "protocol", "terminal": M, "joints": M | null}], "seconds"}``.
"""

from tendon_id.benchmarks.registry import BENCHMARKS, run_benchmark

__all__ = ["BENCHMARKS", "run_benchmark"]
