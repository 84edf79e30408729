"""Names of the benchmarks, what each takes, and how to run one.

The table lists where each benchmark lives rather than importing it, so that listing them
(``tendon-id benchmark --help``) loads none of the models. Each entry names the options of its
runner that a caller may set (the command line's ``--seed``, ``--jobs`` ...) and, for those that
draw one, its page writer, so that one generic ``tendon-id benchmark`` checks a call once,
before any work.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from tendon_id.checks import check_choice, check_count
from tendon_id.errors import ConfigError
from tendon_id.registry import resolve

__all__ = ["BENCHMARKS", "PRESETS", "Benchmark", "format_table", "get_benchmark", "run_benchmark"]

PRESETS = ("fast", "paper")


@dataclass(frozen=True)
class Benchmark:
    """One benchmark.

    Attributes
    ----------
    name : str
    summary : str
        What it reproduces, in one line.
    run, format : str
        ``"module:function"`` of its runner (keyword arguments, returns the JSON object) and of
        its text formatter.
    options : tuple of str
        The runner's keyword arguments a caller may set besides ``preset``.
    page : str, optional
        ``"module:function"`` of its page writer, ``write(result, path) -> Path``.
    """

    name: str
    summary: str
    run: str
    format: str
    options: tuple[str, ...] = ()
    page: str | None = None

    def arguments(self, preset: str = "fast", **given) -> dict:
        """The runner's keyword arguments: ``preset`` and the ``given`` options that are not None, checked.

        Everything the runner would otherwise refuse after its work is checked here, before it:
        the preset, options this benchmark does not take, a count below 1, a recipe that does not
        load, and a joblib backend that is not installed or an ``n_jobs`` it refuses.

        Raises
        ------
        ConfigError
            Naming the option (as the parameter).
        """
        kwargs = {"preset": check_choice("preset", preset, PRESETS)}
        for option, value in given.items():
            if value is None:
                continue
            if option not in self.options:
                takes = ", ".join(self.options) or "none besides preset"
                raise ConfigError(f"the {self.name} benchmark does not take it (its options: {takes})", param=option)
            kwargs[option] = check_count(option, value) if option == "repeats" else value
        if "recipe" in kwargs:
            from tendon_id.datasets import load_recipe

            load_recipe(kwargs["recipe"])
        if "backend" in self.options:  # dask or ray must be installed and registered; n_jobs a non-zero integer
            from tendon_id.benchmarks.jobs import job_runner

            job_runner(kwargs.get("backend", "loky"), kwargs.get("n_jobs", 1))
        return kwargs

    def __call__(self, **kwargs) -> dict:
        """Run the benchmark with checked arguments (:meth:`arguments`)."""
        return resolve(self.run)(**kwargs)

    def check_page(self, path) -> None:
        """Raise ConfigError, naming ``out``, for a benchmark that draws no page or a ``path`` that is not HTML."""
        if self.page is None:
            raise ConfigError(f"the {self.name} benchmark writes no page", param="out")
        if Path(path).suffix.lower() not in (".html", ".htm"):
            raise ConfigError(f"{path}: the page is an HTML file (.html)", param="out")

    def write_page(self, result: dict, path) -> Path:
        """Write the benchmark's page to ``path``; returns it."""
        self.check_page(path)
        return resolve(self.page)(result, path)


def _table(name, summary, run, format, options=(), page=None) -> tuple[str, Benchmark]:
    return name, Benchmark(name, summary, run, format, options, page)


BENCHMARKS: dict[str, Benchmark] = dict(
    [
        _table(
            "table1",
            "paper Table I, single passage (unit level)",
            "tendon_id.benchmarks.tables:table1",
            "tendon_id.benchmarks.tables:format_rows",
            ("recipe", "seed", "repeats"),
        ),
        _table(
            "table2",
            "paper Table II, the cascade on held-out trajectories",
            "tendon_id.benchmarks.tables:table2",
            "tendon_id.benchmarks.tables:format_rows",
            ("recipe", "seed", "repeats"),
        ),
        _table(
            "table3",
            "paper Table III, the estimator in a 10 Hz closed loop on the simulated robot",
            "tendon_id.benchmarks.table3:table3",
            "tendon_id.benchmarks.table3:format_table3",
            ("recipe", "seed", "repeats", "backend", "n_jobs"),
            "tendon_id.report.closed_loop:write_table3_page",
        ),
        _table(
            "recovery",
            "does calibration recover a known law, and does its posterior cover it",
            "tendon_id.benchmarks.recovery:recovery",
            "tendon_id.benchmarks.recovery:format_recovery",
            ("recipe",),
        ),
        _table(
            "sweep",
            "the paper's sensitivity sweep of lambda, lambda_s, eta_w and the window",
            "tendon_id.benchmarks.sweep:sweep",
            "tendon_id.benchmarks.sweep:format_sweep",
            ("recipe", "seed", "points", "backend", "n_jobs"),
        ),
        _table(
            "diagnosis",
            "does the gap diagnosis name a withheld effect (confusion matrix, false alarms, shrinkage)",
            "tendon_id.benchmarks.diagnosis:diagnosis_benchmark",
            "tendon_id.benchmarks.diagnosis:format_diagnosis",
            ("seed", "quick", "backend", "n_jobs"),
        ),
        _table(
            "regimes",
            "when a learned cascade beats calibrated physics: pg-chtc and pg-chtc-ns against capstan-nonsmooth",
            "tendon_id.benchmarks.regimes:regimes",
            "tendon_id.benchmarks.regimes:format_regimes",
            ("recipe", "seed", "backend", "n_jobs"),
            "tendon_id.report.regimes:write_regimes_page",
        ),
        _table(
            "robots",
            "robots that are not the paper's (4 and 2 tendons per set): every command, its time, held-out RMSE",
            "tendon_id.benchmarks.robots:robots",
            "tendon_id.benchmarks.robots:format_robots",
            ("seed",),
        ),
        _table(
            "latency",
            "streaming latency per frame (paper Section IV-B), against batch inference",
            "tendon_id.benchmarks.latency:latency",
            "tendon_id.benchmarks.latency:format_latency",
            ("recipe", "seed"),
        ),
    ]
)


def get_benchmark(name: str) -> Benchmark:
    """The benchmark called ``name`` (ConfigError listing the known ones otherwise)."""
    return BENCHMARKS[check_choice("name", name, BENCHMARKS, what="benchmark")]


def run_benchmark(name: str, *, preset: str = "fast", **options) -> dict:
    """Run benchmark ``name`` and return its JSON object (see the benchmarks guide), checking the call first."""
    b = get_benchmark(name)
    return b(**b.arguments(preset, **options))


def format_table(result: dict) -> str:
    """A benchmark's result as aligned text, by the benchmark's own formatter."""
    return resolve(BENCHMARKS[result["benchmark"]].format)(result)
