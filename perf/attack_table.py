"""Issue 42's hostile cases, before and after, in one run: exit code, the message's last line, time and peak memory.

Usage: python perf/attack_table.py [--before REV] [--json FILE] [--only ID ...]

Each case prepares its input in a scratch folder (a model folder tampered with, a mapping file, a
sidecar's metadata edited, a FIFO...) and runs one ``tendon-id`` command in a fresh process with
that tree's package (``python -m tendon_id`` with the tree first on ``PYTHONPATH``). The inputs
that every case starts from are made by each tree itself: a 300-frame snake recording, a
capstan-simple and a tiny MLP model fitted on it, a synthetic bench file with its mapping, and a
passage-capstan model. ``--before REV`` runs the same cases in a temporary worktree of ``REV``
first (default: ``aced29f``, the last commit before issue 42).

Printed: a markdown table, a row per case, with both trees' exit code and message; ``--json``
writes every field (the whole stderr included).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the cases are the tests' own
from hostile_cases import CASES, prepare  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def run_cli(tree: Path, argv: list[str], cwd: Path, timeout: float) -> dict:
    """``tendon-id ARGV`` of ``tree`` in ``cwd``: exit code, stderr, wall time and peak RSS [MB]."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    env.pop("TENDON_ID_DEBUG", None)
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "tendon_id", *argv], cwd=cwd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    try:
        _, err = proc.communicate(timeout=timeout)
        code = proc.returncode
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
        code = "timeout"
    seconds = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024  # the largest child so far [MB]
    text = err.decode(errors="replace").strip()
    lines = [ln for ln in text.splitlines() if ln.strip()]
    return {
        "code": code,
        "last": lines[-1] if lines else "",
        "n_lines": len(lines),
        "stderr": text,
        "seconds": round(seconds, 2),
        "peak_mb_upper": round(peak, 1),
    }


def run_tree(tree: Path, only: set[str] | None) -> dict[str, dict]:
    out = {}
    with tempfile.TemporaryDirectory(prefix="attack-") as tmp:
        base = Path(tmp) / "base"
        prepare(lambda argv, cwd: run_cli(tree, argv, cwd, 600), base)
        for case in CASES:
            if only and case.id not in only:
                continue
            work = Path(tmp) / case.id
            work.mkdir()
            argv = case.setup(base, work)
            out[case.id] = run_cli(tree, argv, work, case.timeout)
            out[case.id]["after"] = case.after(work) if case.after else None
            print(f"  {tree.name}: {case.id}: {out[case.id]['code']} {out[case.id]['last'][:100]}", flush=True)
    return out


def cell(r: dict) -> str:
    """One tree's result as a table cell: exit code, message, time where long, and what was left behind."""
    text = f"{r['code']}: {r['last'][:140]}".replace("|", "\\|")
    text += f" ({r['seconds']:.0f} s)" if r["seconds"] > 30 else ""
    return text + (f"; {r['after']}" if r["after"] else "")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", default="aced29f")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--only", nargs="*")
    args = ap.parse_args()
    only = set(args.only) if args.only else None
    with tempfile.TemporaryDirectory(prefix="attack-before-") as wt:
        subprocess.run(
            ["git", "worktree", "add", "--detach", wt, args.before], cwd=ROOT, check=True, capture_output=True
        )
        try:
            before = run_tree(Path(wt), only)
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", wt], cwd=ROOT, capture_output=True)
    after = run_tree(ROOT, only)
    print("\n| # | case | before | after |\n|---|---|---|---|")
    for case in CASES:
        if case.id not in after:
            continue
        b, a = before[case.id], after[case.id]
        print(f"| {case.id} | {case.what} | {cell(b)} | {cell(a)} |")
    if args.json:
        args.json.write_text(
            json.dumps(
                {"before_rev": args.before, "before": before, "after": after},
                indent=1,
                default=lambda o: o.item() if isinstance(o, np.generic) else str(o),
            )
        )


if __name__ == "__main__":
    main()
