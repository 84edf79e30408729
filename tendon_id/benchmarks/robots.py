"""Robots that are not the paper's, every command end to end: its time, and the held-out error against the truth.

For each bundled robot that is not the paper's (``snake6-quad``: 6 modules, 4 tendons per set;
``planar6-pair``: 6 hinges, 2 tendons per joint; :doc:`/guide/robot_file`) the command line is run
as a user runs it, one process per command, each timed as a whole: ``simulate`` (training data:
terminal-only scans and posterior-3 steps; held-out data: posterior-6 steps of another seed),
``fit`` and ``evaluate --json`` of ``proximal``, ``capstan-nonsmooth`` and ``pg-chtc``,
``calibrate --posterior``, ``identifiability`` and ``diagnose``. Streaming is measured in this
process: PG-CHTC's streamer over every held-out frame, against its batch ``predict``.

The held-out error is the one ``evaluate`` reports against the simulator's truth: the terminal
joint (what a robot measures) and the intermediate joints ``2..N-1`` (what only a simulator knows).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

__all__ = ["ROBOT_RECIPES", "format_robots", "robots"]

#: The bundled recipes of robots that are not the paper's.
ROBOT_RECIPES = ("snake6-quad", "planar6-pair")
#: Models fitted and evaluated on each robot.
MODELS = ("proximal", "capstan-nonsmooth", "pg-chtc")


def _run(args: list[str], work: Path, env: dict) -> tuple[float, str]:
    """Run ``tendon-id ARGS`` in ``work``; its wall time [s] and standard output. Raises on a non-zero exit."""
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "tendon_id", *args], cwd=work, env=env, capture_output=True, text=True, check=False
    )
    seconds = time.perf_counter() - t0
    if done.returncode != 0:
        raise RuntimeError(f"tendon-id {' '.join(args)} exited {done.returncode}: {done.stderr.strip()[-400:]}")
    return seconds, done.stdout


def _stream(model_dir: Path, test: Path) -> dict:
    """PG-CHTC's streamer over every held-out frame: its deviation from batch ``predict`` and its time per frame."""
    from tendon_id.data import Recording
    from tendon_id.zoo import load

    model = load(model_dir)
    rec = Recording.read(test)
    batch = model.predict(rec)
    stream = model.streamer()
    out = np.full_like(batch, np.nan)
    starts = rec.trajectory_starts
    t0 = time.perf_counter()
    for t in range(rec.n_frames):
        if starts[t]:
            stream.reset()
        out[t] = stream.step(rec.angles[t], rec.actuator[t])
    per_frame = (time.perf_counter() - t0) / rec.n_frames
    ok = np.isfinite(batch) & np.isfinite(out)
    return {
        "frames": int(rec.n_frames),
        "per_frame_ms": 1e3 * per_frame,
        "max_abs_diff_n": float(np.max(np.abs(out[ok] - batch[ok]))) if ok.any() else None,
        "compared": int(ok.sum()),
    }


def _one_robot(recipe: str, preset: str, seed: int, work: Path, env: dict) -> dict:
    commands: list[dict] = []

    def run(*args: str) -> str:
        seconds, stdout = _run(list(args), work, env)
        commands.append({"command": "tendon-id " + " ".join(args), "seconds": round(seconds, 2)})
        return stdout

    s = str(seed)
    run("simulate", "--recipe", recipe, "--protocol", "terminal-only", "--frames", "4000", "--seed", s,
        "--out", "scan.parquet")  # fmt: skip
    run("simulate", "--recipe", recipe, "--protocol", "posterior-3", "--frames", "2000", "--seed", s,
        "--out", "steps.parquet")  # fmt: skip
    run("simulate", "--recipe", recipe, "--protocol", "posterior-6", "--frames", "1000", "--seed", str(seed + 1),
        "--out", "test.parquet")  # fmt: skip
    train = ["--data", "scan.parquet", "--data", "steps.parquet"]
    heldout = {}
    for model in MODELS:
        extra = ["--set", f"preset={preset}"] if model == "pg-chtc" else []
        run("fit", model, *train, *extra, "--out", f"models/{model}")
        metrics = json.loads(run("evaluate", "--model", f"models/{model}", "--data", "test.parquet", "--json", "-"))
        joints = metrics.get("joints") or {}
        heldout[model] = {
            "terminal_rmse_n": metrics["terminal"]["rmse"],
            "intermediate_rmse_n": (joints.get("overall") or {}).get("rmse"),
        }
    run("calibrate", *train, "--model", "capstan-contact", "--posterior", "--out", "calibration")
    run("identifiability", *train, "--out", "identifiability.html")
    run("diagnose", *train, "--test", "test.parquet", "--base", "capstan-nonsmooth", "--out", "diagnosis.html")
    t0 = time.perf_counter()
    streaming = _stream(work / "models" / "pg-chtc", work / "test.parquet")
    commands.append(
        {"command": "PG-CHTC streamer over test.parquet (in process)", "seconds": round(time.perf_counter() - t0, 2)}
    )
    from tendon_id.datasets import load_recipe

    robot = load_recipe(recipe).robot
    return {
        "recipe": recipe,
        "n_modules": robot.n_modules,
        "n_tendons": robot.n_tendons,
        "bending_axes": robot.bending_axes,
        "commands": commands,
        "heldout": heldout,
        "streaming": streaming,
        "seconds": round(sum(c["seconds"] for c in commands), 1),
    }


def robots(preset: str = "fast", seed: int = 0) -> dict:
    """Run every command on each robot of :data:`ROBOT_RECIPES` (see the module docstring).

    Parameters
    ----------
    preset : str
        PG-CHTC's preset (``fast`` or ``paper``).
    seed : int
        Seed of the training data; the held-out data take ``seed + 1``.

    Returns
    -------
    dict
        ``{"benchmark": "robots", "preset", "seed", "robots": [per robot: "commands" (command, seconds),
        "heldout" (per model: terminal and intermediate RMSE [N]), "streaming" (per-frame time [ms],
        largest deviation from batch predict [N])]}``.
    """
    out = []
    with tempfile.TemporaryDirectory(prefix="tendon-id-robots-") as tmp:
        for recipe in ROBOT_RECIPES:
            work = Path(tmp) / recipe
            work.mkdir()
            env = {**os.environ, "TENDON_ID_CACHE": str(Path(tmp) / "cache")}
            out.append(_one_robot(recipe, preset, seed, work, env))
    return {"benchmark": "robots", "preset": preset, "seed": seed, "robots": out}


def format_robots(result: dict) -> str:
    """The commands with their times, then the held-out RMSE of each model, per robot."""
    lines = []
    for r in result["robots"]:
        lines.append(f"{r['recipe']}: {r['n_modules']} modules, {r['n_tendons']} tendons per set, "
                     f"{r['bending_axes']} bending axes ({r['seconds']:.0f} s in all)")  # fmt: skip
        lines += [f"  {c['seconds']:7.1f} s  {c['command']}" for c in r["commands"]]
        lines.append("  held-out RMSE against the truth [N]:   terminal   intermediate 2..N-1")
        for model, h in r["heldout"].items():
            inter = "-" if h["intermediate_rmse_n"] is None else f"{h['intermediate_rmse_n']:.2f}"
            lines.append(f"    {model:20s} {h['terminal_rmse_n']:19.2f}   {inter:>12s}")
        s = r["streaming"]
        diff = "-" if s["max_abs_diff_n"] is None else f"{s['max_abs_diff_n']:.2e} N"
        lines.append(f"  streaming pg-chtc: {s['per_frame_ms']:.3f} ms per frame, largest deviation from batch {diff}")
    return "\n".join(lines)
