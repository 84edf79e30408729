"""``tendon-id calibrate --each``: many recordings calibrated at once, one result per file (:doc:`/guide/calibration`).

A fleet (one recording per robot, per day, per bench run) is calibrated file by file, each on its
own, as independent :class:`joblib.Parallel` jobs. No backend is named here, so whatever
:func:`joblib.parallel_config` is active runs them: loky's processes by default, threads, or a
Dask cluster (``with parallel_config(backend="dask")`` and a ``dask.distributed.Client``) unchanged.

Every file is read and checked before any job starts, so a bad file costs no fitting. A job
computes only (:func:`~tendon_id.report.calibration.fit_calibration`) and returns the fitted model;
this process writes each file's folder as its result arrives
(:func:`~tendon_id.report.calibration.write_calibration`, the files ``tendon-id calibrate`` writes).
Writing here rather than in the workers keeps the writes atomic and under one Ctrl-C, names them
in the interrupt's message, and needs no file system shared with the workers.
"""

from __future__ import annotations

import math
import os
import time
import warnings
from collections.abc import Callable, Sequence
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path

from joblib import Parallel, delayed

from tendon_id.atomic import check_writable, write_group, write_json_atomic
from tendon_id.checks import check_jobs
from tendon_id.data.mapping import DataMapping, load_mapping, read_files
from tendon_id.errors import ConfigError, RecordingError, TendonIdError
from tendon_id.progress import progress_bar
from tendon_id.report.calibration import calibration_model, fit_calibration, write_calibration

__all__ = ["FLEET_FILE", "FileCalibration", "calibrate_fleet", "calibrate_one", "fleet_names"]

#: The fleet's summary, beside the files' folders.
FLEET_FILE = "fleet.json"


@dataclass
class FileCalibration:
    """What one file's job returns: the calibrated model and its document, or why there is none.

    Attributes
    ----------
    status : str
        ``"ok"``; ``"refused"`` (the data was refused at fit time, or the calibration came out
        non-finite); ``"failed"`` (an unexpected error: a bug).
    seconds : float
        Wall time of the job [s].
    reason : str
        Why it is not ``"ok"`` (empty when it is).
    fitted : Estimator or None
        The calibrated model.
    doc : dict or None
        Its ``calibration.json``.
    figures : dict
        The family's headline numbers of ``doc`` (:meth:`~tendon_id.family.Family.calibration_figures`).
    warnings : list of (str, type)
        The warnings the job raised, message and category, for the caller to show.
    """

    status: str
    seconds: float
    reason: str = ""
    fitted: object = None
    doc: dict | None = None
    figures: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)


def calibrate_one(
    recording, *, model: str, settings: dict | None = None, seed: int = 0, record_warnings: bool = False
) -> FileCalibration:
    """Calibrate ``model`` on one recording: the job of :func:`calibrate_fleet`, run in a worker.

    It never raises for one file's trouble, so that the other files' results are kept: the
    refusal or the error is returned as the status.

    Parameters
    ----------
    recording : recording
        Of the model's family.
    model : str
        A registered model with a law.
    settings : dict, optional
        The model's settings.
    seed : int
        Seeds the multi-start.
    record_warnings : bool
        Return the warnings (in ``warnings`` of the result) instead of showing them. Only
        for a process of its own: the record swaps the process's warning filters, which
        threads share.

    Returns
    -------
    FileCalibration
    """
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) if record_warnings else nullcontext() as caught:
        if record_warnings:
            warnings.simplefilter("always")
        try:
            fitted, doc = fit_calibration([recording], model=model, settings=settings, seed=seed)
            figures = fitted.family.calibration_figures(doc)
            result = FileCalibration("ok", 0.0, fitted=fitted, doc=doc, figures=figures)
            bad = [k for k in ("rmse", "loss") if figures.get(k) is not None and not math.isfinite(figures[k])]
            if bad:  # nothing usable to write: a law that predicts NaN is no calibration
                result = FileCalibration("refused", 0.0, reason=f"the calibration is not finite ({', '.join(bad)})")
        except TendonIdError as exc:  # the data or the settings, as the command line's exit code 2
            result = FileCalibration("refused", 0.0, reason=str(exc))
        except Exception as exc:  # noqa: BLE001 - one file's bug must not lose the others' results
            result = FileCalibration("failed", 0.0, reason=f"internal error: {type(exc).__name__}: {exc}")
    result.seconds = time.perf_counter() - t0
    result.warnings = [(str(w.message), w.category) for w in caught or ()]
    return result


def _job(recording, model: str, settings: dict, seed: int, caller: int) -> FileCalibration:
    """:func:`calibrate_one` as a joblib job: in another process than the ``caller``'s (a pid), the
    warnings come back to be shown there, once, on the user's terminal; in the caller's own (one
    job, threads) they are shown as they arise."""
    return calibrate_one(recording, model=model, settings=settings, seed=seed, record_warnings=os.getpid() != caller)


def fleet_names(paths: Sequence[str | os.PathLike]) -> list[str]:
    """The folder of each file's result: its stem, with ``-2``, ``-3`` ... where stems repeat.

    Names are compared case-blind, since two folders that differ only in case are one folder on
    macOS and Windows. The first file of a stem keeps it; the order of ``paths`` decides.
    """
    used = {FLEET_FILE.casefold()}  # a file called fleet.json.csv must not take the summary's place
    names = []
    for p in paths:
        stem = Path(p).stem
        name, k = stem, 2
        while name.casefold() in used:
            name, k = f"{stem}-{k}", k + 1
        used.add(name.casefold())
        names.append(name)
    return names


def _read_every(paths: list[Path], mapping: DataMapping | None, family) -> list:
    """Every file's recording, read one by one so that every bad file is found before any fit.

    Each file is read on its own, as ``tendon-id calibrate --data FILE`` reads it (its
    trajectory is its stem). The first bad file's error is raised, naming the others.
    """
    recordings, bad = [], []
    for p in paths:
        try:
            rec = read_files([p], mapping)[0]
            family.recordings(rec, "data")  # a file of another family: refused now, not in its job
        except RecordingError as exc:
            bad.append(exc if exc.file else RecordingError(exc.reason, file=str(p), column=exc.column, row=exc.row))
        except TendonIdError as exc:
            bad.append(RecordingError(str(exc), file=str(p)))
        else:
            recordings.append(rec)
    if bad:
        first = bad[0]
        more = f" ({len(bad) - 1} more files cannot be calibrated: {', '.join(e.file for e in bad[1:])})"
        raise RecordingError(
            first.reason + (more if len(bad) > 1 else ""), file=first.file, column=first.column, row=first.row
        )
    return recordings


def _check_folders(out: Path, names: list[str]) -> None:
    """Raise ConfigError, before any work, where a folder stands in the summary's place or a file in a result's."""
    if (out / FLEET_FILE).is_dir():
        raise ConfigError(f"{out / FLEET_FILE}: is a folder, where the fleet's summary goes", param="out")
    for name in names:
        if (out / name).exists() and not (out / name).is_dir():
            raise ConfigError(f"{out / name}: is a file, where a folder of results goes", param="out")


def _line(path: Path, entry: dict, model: str, out: Path) -> str:
    if entry["status"] != "ok":
        return f"{path}: {entry['status']}, nothing written"
    fig = f" RMSE {entry['rmse']:.4g} {entry['unit']}" if "rmse" in entry else ""
    return f"{path}: {model}{fig} on {entry['frames']} frames -> {out / entry['name']}"


def calibrate_fleet(
    paths: Sequence[str | os.PathLike],
    *,
    model: str,
    settings: dict | None = None,
    out: str | os.PathLike,
    seed: int = 0,
    n_jobs: int | None = None,
    mapping: DataMapping | str | os.PathLike | None = None,
    report: Callable[[str], None] | None = None,
) -> dict:
    """Calibrate ``model`` on each file on its own; write ``out/<name>/`` per file and ``out/fleet.json``.

    Parameters
    ----------
    paths : sequence of path-like
        The recordings, one calibration each.
    model : str
        A registered model with a law (:func:`~tendon_id.report.calibration.law_models`).
    settings : dict, optional
        The model's settings (``tying``, ``blocks``), the same for every file.
    out : path-like
        The output folder. ``out/<name>/`` gets the file's ``calibration.json`` and ``model/``
        (as ``tendon-id calibrate`` writes them; ``<name>`` from :func:`fleet_names`), and
        ``out/fleet.json`` one entry per file.
    seed : int
        Seeds every file's multi-start, the same seed for each: a file's result is the one it
        gets calibrated alone, whatever the other files, their order or ``n_jobs``.
    n_jobs : int, optional
        Parallel jobs (joblib's meaning: None is 1 unless a :func:`joblib.parallel_config` says
        otherwise, -1 every core). The backend is the active ``parallel_config``'s.
    mapping : DataMapping or path-like, optional
        How to read a user's own files (:func:`~tendon_id.data.mapping.load_mapping`'s, or its
        TOML file).
    report : callable, optional
        Called with one line per file as its result is written.

    Returns
    -------
    dict
        What ``fleet.json`` holds: ``{"model", "settings", "seed", "files", "ok", "refused",
        "failed", "seconds", "entries"}``. Each entry is ``{"file", "name", "frames", "status",
        "seconds"}`` plus, when ``"ok"``, the family's ``rmse`` [``unit``], ``unit`` and ``loss``,
        and otherwise ``reason``. ``seconds`` are wall times [s], the only numbers that differ
        between two runs.

    Raises
    ------
    ConfigError
        Before any file is read: for a model without a law, a bad setting, ``n_jobs`` or ``out``.
    RecordingError
        Before any fit: naming the first file that cannot be read or is of another family (and
        the others that cannot).
    """
    t0 = time.perf_counter()
    paths = [Path(p) for p in paths]
    if not paths:
        raise ConfigError("give at least one recording", param="paths")
    settings = dict(settings or {})
    family = calibration_model(model, settings, seed).family  # a bad model or setting: before any file
    n_jobs = None if n_jobs is None else check_jobs("n_jobs", n_jobs)
    out = check_writable(out, "out", folder=True)
    names = fleet_names(paths)
    _check_folders(out, names)
    if mapping is not None and not isinstance(mapping, DataMapping):
        mapping = load_mapping(mapping)
    recordings = _read_every(paths, mapping, family)
    report = report or (lambda line: None)

    jobs = (delayed(_job)(r, model, settings, seed, os.getpid()) for r in recordings)
    results = Parallel(n_jobs=n_jobs, return_as="generator")(jobs)  # in order, each as soon as it is done
    entries = []
    for path, name, rec, result in progress_bar(
        zip(paths, names, recordings, results), desc="file", total=len(paths), unit=""
    ):
        for message, category in result.warnings:
            warnings.warn(message, category, stacklevel=2)
        entry = {"file": str(path), "name": name, "frames": rec.n_frames, "status": result.status}
        if result.status == "ok":
            with write_group(out / name):  # one writer per folder, and a Ctrl-C waits for the whole file
                write_calibration(result.fitted, result.doc, out / name)
            entry.update(result.figures)
        else:
            entry["reason"] = result.reason
        entry["seconds"] = result.seconds
        entries.append(entry)
        report(_line(path, entry, model, out))
    counts = {s: sum(e["status"] == s for e in entries) for s in ("ok", "refused", "failed")}
    doc = {"model": model, "settings": settings, "seed": seed, "files": len(entries), **counts}
    doc.update(seconds=time.perf_counter() - t0, entries=entries)
    write_json_atomic(out / FLEET_FILE, doc)
    return doc
