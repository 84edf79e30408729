"""Names of the benchmarks and how to run one.

The table lists where each benchmark lives rather than importing it, so that listing them
(``tendon-id benchmark --help``) loads none of the models.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass

from tendon_id.errors import ConfigError


@dataclass(frozen=True)
class Benchmark:
    """One benchmark: what it reproduces, and its ``"module:function"`` runner and formatter."""

    summary: str
    run: str
    format: str

    def __call__(self, **kwargs) -> dict:
        """Run the benchmark (as the plain function this registry held before it was lazy)."""
        return self.resolve(self.run)(**kwargs)

    @staticmethod
    def resolve(path: str) -> Callable:
        module, _, attr = path.partition(":")
        return getattr(importlib.import_module(module), attr)


BENCHMARKS: dict[str, Benchmark] = {
    "table1": Benchmark(
        "paper Table I, single passage (unit level)",
        "tendon_id.benchmarks.tables:table1",
        "tendon_id.benchmarks.tables:format_rows",
    ),
    "table2": Benchmark(
        "paper Table II, the cascade on held-out trajectories",
        "tendon_id.benchmarks.tables:table2",
        "tendon_id.benchmarks.tables:format_rows",
    ),
    "table3": Benchmark(
        "paper Table III, the estimator in a 10 Hz closed loop on the simulated robot",
        "tendon_id.benchmarks.table3:table3",
        "tendon_id.benchmarks.table3:format_table3",
    ),
    "recovery": Benchmark(
        "does calibration recover a known law, and does its posterior cover it",
        "tendon_id.benchmarks.recovery:recovery",
        "tendon_id.benchmarks.recovery:format_recovery",
    ),
    "sweep": Benchmark(
        "the paper's sensitivity sweep of lambda, lambda_s, eta_w and the window",
        "tendon_id.benchmarks.sweep:sweep",
        "tendon_id.benchmarks.sweep:format_sweep",
    ),
    "diagnosis": Benchmark(
        "does the gap diagnosis name a withheld effect (confusion matrix, false alarms, shrinkage)",
        "tendon_id.benchmarks.diagnosis:diagnosis_benchmark",
        "tendon_id.benchmarks.diagnosis:format_diagnosis",
    ),
    "regimes": Benchmark(
        "when a learned cascade beats calibrated physics: pg-chtc and pg-chtc-ns against capstan-nonsmooth",
        "tendon_id.benchmarks.regimes:regimes",
        "tendon_id.benchmarks.regimes:format_regimes",
    ),
    "latency": Benchmark(
        "streaming latency per frame (paper Section IV-B), against batch inference",
        "tendon_id.benchmarks.latency:latency",
        "tendon_id.benchmarks.latency:format_latency",
    ),
}
PRESETS = ("fast", "paper")


def run_benchmark(name: str, *, preset: str = "fast", **kwargs) -> dict:
    """Run benchmark ``name`` and return its JSON object (DESIGN §10)."""
    if name not in BENCHMARKS:
        raise ConfigError(f"unknown benchmark {name!r}; known: {', '.join(BENCHMARKS)}")
    if preset not in PRESETS:
        raise ConfigError(f"unknown preset {preset!r}; known: {', '.join(PRESETS)}")
    return BENCHMARKS[name](preset=preset, **kwargs)


def format_table(result: dict) -> str:
    """A benchmark's result as aligned text, by the benchmark's own formatter."""
    return Benchmark.resolve(BENCHMARKS[result["benchmark"]].format)(result)
