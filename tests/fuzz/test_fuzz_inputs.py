"""Fuzzed input files: read -> validate -> fit (capstan-simple) -> evaluate never crashes (issue 19, item 1).

Each example starts from a small valid simulated recording (N = 2 or 3, two trajectories of 12
frames), applies one or several defects (:mod:`defects`), writes the file and sends it through
the library (``Recording.read``, ``fit``, ``score``) and through the command line (``tendon-id
fit`` and ``tendon-id evaluate --json``, called in-process). Every outcome must be

- a result whose metrics are finite numbers (but R^2 where the reference never varies, as in a
  one-frame recording: 0/0 is NaN), or
- an error of the project's own classes (:class:`~tendon_id.errors.TendonIdError`), which the
  command line reports as exit code 2 with one line and no traceback,

never an exit 1, a bare ``KeyError``/``ValueError``/..., a traceback or a hang. The library and
the command line must agree: a file is refused by both or by neither.

The CI part runs a few hundred examples (``PER_KIND`` per defect kind alone, ``COMBINED`` of
several kinds). ``test_fuzz_10000`` (marked slow; ``$TENDON_ID_FUZZ_EXAMPLES`` changes the count)
writes a tally of outcomes per defect to ``$TENDON_ID_FUZZ_TALLY`` (JSON) when set, and prints it
(``pytest -s -m slow``).
"""

from __future__ import annotations

import io
import json
import math
import os
import re
import signal
import sys
import tempfile
import time
import warnings
from collections import Counter, defaultdict
from contextlib import contextmanager, redirect_stderr, redirect_stdout
from dataclasses import dataclass, field
from datetime import timedelta
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings

sys.path.insert(0, str(Path(__file__).resolve().parent))
from defects import KINDS, documents, label  # noqa: E402

from tendon_id import zoo  # noqa: E402
from tendon_id.cli import main  # noqa: E402
from tendon_id.data import Recording  # noqa: E402
from tendon_id.errors import TendonIdError  # noqa: E402

#: An example slower than this is a hang [s] (a real one takes well under a second).
HANG_S = 60

#: Examples in CI: per defect kind alone, and of several kinds together (a few hundred in all).
PER_KIND, COMBINED = 20, 200

FUZZ = dict(
    derandomize=True,
    # An example takes ~50 ms; the deadline is generous so that a busy CI machine does not flake,
    # and hang_guard stops one that never returns.
    deadline=timedelta(seconds=20),
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    print_blob=True,
)


@dataclass
class Outcome:
    """What one path (library or CLI) made of a file."""

    status: str  # "result" or "error"
    stage: str  # read, fit, evaluate
    error: str | None = None  # error class name
    message: str = ""
    numbers: dict | None = None
    warnings: list[str] = field(default_factory=list)
    undefined: frozenset = frozenset()  # metrics that may be NaN: R^2 of a constant reference

    @property
    def key(self) -> str:
        return "result" if self.status == "result" else f"{self.error}@{self.stage}"


class Hang(Exception):
    pass


@contextmanager
def hang_guard(seconds: float = HANG_S):
    """Raise :class:`Hang` in the main thread after ``seconds``."""

    def _alarm(signum, frame):
        raise Hang(f"an example took more than {seconds} s")

    if not hasattr(signal, "SIGALRM"):  # pragma: no cover (Windows)
        yield
        return
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def _non_finite(obj, path="") -> list[str]:
    """Paths of the non-finite numbers in a metrics object."""
    if isinstance(obj, dict):
        return [p for k, v in obj.items() for p in _non_finite(v, f"{path}.{k}")]
    if isinstance(obj, (list, tuple)):
        return [p for i, v in enumerate(obj) for p in _non_finite(v, f"{path}[{i}]")]
    if isinstance(obj, bool) or obj is None or isinstance(obj, str):
        return []
    return [] if math.isfinite(float(obj)) else [f"{path}={obj}"]


def _reason(message: str) -> str:
    """An error message without the file, numbers and quoted values: a key for the tally."""
    text = re.sub(r"^\S*(\.parquet|\.csv|\.json)\b[^:]*: ", "", message)
    text = re.sub(r"'[^']*'", "'…'", text)
    text = re.sub(r"-?\d[\d.e+-]*", "#", text)
    return text[:90]


def _constant(a) -> bool:
    """True when every tendon of ``a`` (shape (T, ..., 3)) has one value: its R^2 is undefined (0/0)."""
    a = np.asarray(a).reshape(a.shape[0], -1, 3)
    return bool(np.all(a.max(axis=0) == a.min(axis=0)))


def undefined_r2(rec: Recording) -> frozenset:
    """The metrics paths whose R^2 is 0/0 on ``rec``: its reference does not vary (one frame, a held load)."""
    out = set()
    if _constant(rec.terminal):
        out.add(".terminal.r2")
    truth = rec.joint_truth
    if truth is not None:
        n = truth.shape[1]
        out.update(f".joints.per_joint[{j}].r2" for j in range(n) if _constant(truth[:, j]))
        if n > 2 and _constant(truth[:, 1 : n - 1]):
            out.add(".joints.overall.r2")
    return frozenset(out)


def library(path: Path) -> Outcome:
    """``Recording.read`` -> ``capstan-simple`` fit -> ``score``; an error of another class propagates."""
    stage = "read"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            rec = Recording.read(path)
            stage = "fit"
            model = zoo.make("capstan-simple").fit(rec)
            stage = "evaluate"
            score = model.score(rec)
        except TendonIdError as exc:
            return Outcome("error", stage, type(exc).__name__, getattr(exc, "reason", None) or str(exc))
    caught = [f"{w.category.__name__}: {w.message}" for w in caught]
    return Outcome("result", stage, numbers=score, warnings=caught, undefined=undefined_r2(rec))


def cli(*argv: str) -> tuple[int, str, str, list[str]]:
    """Run ``tendon-id`` in-process: exit code, stdout, stderr and the Python warnings raised."""
    out, err = io.StringIO(), io.StringIO()
    with warnings.catch_warnings(record=True) as caught, redirect_stdout(out), redirect_stderr(err):
        warnings.simplefilter("always")
        try:
            code = main(list(argv))
        except SystemExit as exc:  # the parser's own exits
            code = exc.code if isinstance(exc.code, int) else 1
    return code, out.getvalue(), err.getvalue(), [f"{w.category.__name__}: {w.message}" for w in caught]


def command_line(path: Path, folder: Path) -> Outcome:
    """``tendon-id fit capstan-simple`` then ``tendon-id evaluate --json``, checking the exit contract."""
    model = folder / "model"
    for stage, argv in (
        ("fit", ("fit", "capstan-simple", "--data", str(path), "--out", str(model))),
        ("evaluate", ("evaluate", "--model", str(model), "--data", str(path), "--json")),
    ):
        code, out, err, caught = cli(*argv)
        assert "Traceback" not in err, f"{stage}: a traceback\n{err}"
        assert code in (0, 2), f"{stage}: exit {code} (0 ok or 2 bad input expected)\n{err}"
        if code == 2:
            line = err.strip()
            assert line.startswith("tendon-id: error: "), f"{stage}: not our error line: {err!r}"
            assert "\n" not in line, f"{stage}: more than one line on stderr: {err!r}"
            assert "internal error" not in line, line
            return Outcome("error", stage, "exit 2", line)
    doc = json.loads(out)
    return Outcome(
        "result", "evaluate", numbers={"terminal": doc["terminal"], "joints": doc["joints"]}, warnings=caught
    )


def check_result(outcome: Outcome, where: str) -> None:
    """A result's metrics are finite, but for the R^2 of a reference that never varies (0/0: NaN)."""
    if outcome.status != "result":
        return
    bad = [p for p in _non_finite(outcome.numbers) if not (p.endswith("=nan") and p[:-4] in outcome.undefined)]
    assert not bad, f"{where}: a result with non-finite metrics {bad} (warnings: {outcome.warnings})"


TALLY: dict[str, Counter] = defaultdict(Counter)
REASONS: Counter = Counter()
TIMES: list[float] = []


def run_example(doc, specs) -> tuple[Outcome, Outcome]:
    """Write ``doc``, run both paths, check the property and tally the outcome."""
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp, hang_guard():
        folder = Path(tmp)
        path = doc.write(folder)
        lib = library(path)
        check_result(lib, "library")
        if lib.status == "error":
            assert "\n" not in str(lib.message), f"a multi-line error: {lib.message!r}"
        cmd = command_line(path, folder)
        cmd.undefined = lib.undefined
        check_result(cmd, "CLI")
    # The CLI reads files as the library does: bad input is refused by both or by neither
    # (a file whose metadata says it holds a single passage reads as a passage on the command line).
    passage = isinstance(doc.meta, dict) and doc.meta.get("kind") == "passage"
    if not passage:
        assert (lib.status == "error") == (cmd.status == "error"), (
            f"library and CLI disagree: library {lib.key} {lib.message!r}, CLI {cmd.key} {cmd.message!r}"
        )
    TIMES.append(time.perf_counter() - t0)
    key = lib.key if not (lib.status == "result" and lib.undefined) else "result (R2 undefined: constant reference)"
    for spec in specs:
        TALLY[label(spec)][key] += 1
        TALLY[f"{spec[0]} (all)"][key] += 1
    TALLY["(every example)"][key] += 1
    TALLY["(every example, CLI)"][cmd.key] += 1
    if lib.status == "error":
        REASONS[f"{lib.error}: {_reason(lib.message)}"] += 1
    return lib, cmd


# ---- CI: a few hundred examples -----------------------------------------------------------


def _single(kind):
    return documents(kinds=[kind], max_defects=2)


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_each_defect_kind_is_a_result_or_a_documented_error(kind):
    """Each kind alone (one or two defects of it): 20 examples per kind."""

    @settings(max_examples=PER_KIND, **FUZZ)
    @given(_single(kind))
    def run(case):
        run_example(*case)

    run()


@settings(max_examples=COMBINED, **FUZZ)
@given(documents(max_defects=4))
def test_combined_defects_are_a_result_or_a_documented_error(case):
    """One to four defects of any kinds together."""
    run_example(*case)


# ---- slow: 10 000 examples, with a tally --------------------------------------------------


@pytest.mark.slow
def test_fuzz_10000():
    """10 000 examples of one to four defects; the tally goes to $TENDON_ID_FUZZ_TALLY and stdout."""
    n = int(os.environ.get("TENDON_ID_FUZZ_EXAMPLES", "10000"))
    TALLY.clear()
    REASONS.clear()
    TIMES.clear()
    t0 = time.perf_counter()

    @settings(max_examples=n, **FUZZ)
    @given(documents(max_defects=4))
    def run(case):
        run_example(*case)

    try:
        run()
    finally:
        report = {
            "examples_run": len(TIMES),
            "examples_requested": n,
            "seconds": round(time.perf_counter() - t0, 1),
            "median_example_s": round(sorted(TIMES)[len(TIMES) // 2], 4) if TIMES else None,
            "max_example_s": round(max(TIMES), 3) if TIMES else None,
            "tally": {k: dict(v.most_common()) for k, v in sorted(TALLY.items())},
            "reasons": dict(REASONS.most_common()),
        }
        target = os.environ.get("TENDON_ID_FUZZ_TALLY")
        if target:
            Path(target).write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
        print(json.dumps(report, indent=2))
