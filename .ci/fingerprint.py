#!/usr/bin/env python3
"""Byte fingerprints of what the command line writes, to show that a refactoring changed no behaviour.

    python .ci/fingerprint.py run OUT.json [--tree DIR] [--bench DIR]
    python .ci/fingerprint.py compare BEFORE.json AFTER.json

``run`` executes a fixed list of ``tendon-id`` commands in a scratch folder, with the code of
``--tree`` (default: this checkout; give a ``git worktree`` of an older commit to fingerprint
it), and records the SHA-256 of every file and every JSON document they write. Fields that time
the work (``seconds``, ``wall_s`` ...) are removed from JSON before hashing; nothing else is. A
model folder is hashed file by file (``model.json`` without its timings, ``arrays.npz`` as bytes).

``compare`` prints each fingerprint that differs, and where it differs: ``run`` keeps every
JSON document it hashed (timings removed) in ``OUT.docs/``, and ``compare`` names the first
fields whose values differ and by how much. It exits 1 if any fingerprint differs.

The cases cover ``simulate``, ``fit`` + ``evaluate --json`` of every zoo model, ``calibrate``
(snake, and the bench passage through its mapping), ``calibrate --posterior`` (both),
``identifiability --json`` and ``diagnose --json`` (snake, and the bench passage). The bench
files are read from ``--bench`` (default: ``../shared/data/real/mis-tool-characterization``
beside the checkout); the bench cases are skipped, and say so, where it is missing.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_BENCH = ROOT.parent / "shared" / "data" / "real" / "mis-tool-characterization" / "Tool_4_Maryland_L_2"
#: JSON keys that time the work: left out of the hash.
TIMING_KEYS = {"seconds", "wall_s", "first_s", "median_s", "all_s"}

ZOO = [
    ("proximal", []),
    ("capstan-simple", []),
    ("capstan-contact", []),
    ("capstan-nonsmooth", []),
    ("capstan-const-mu", []),
    ("capstan", ["--set", 'blocks=["contact", "viscoelastic"]']),
    ("mlp", []),
    ("lstm", []),
    ("transformer", []),
    ("pg-chtc", []),
    ("pg-chtc-ns", []),
]
BENCH_TRAIN = ["00.TXT", "11.TXT", "22.TXT"]
BENCH_TEST = ["33.TXT", "42.TXT"]


def strip(obj):
    """``obj`` without the timing fields, recursively."""
    if isinstance(obj, dict):
        return {k: strip(v) for k, v in obj.items() if k not in TIMING_KEYS}
    if isinstance(obj, list):
        return [strip(v) for v in obj]
    return obj


#: Where each JSON document hashed is kept (set by ``run``), by its digest.
DOCS: dict[str, object] = {}


def digest_json(text: str) -> str:
    doc = strip(json.loads(text))
    digest = hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()
    DOCS[digest] = doc
    return digest


def digest_path(path: Path) -> dict[str, str]:
    """SHA-256 of a file, or of each file of a folder (JSON without its timings)."""
    files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
    out = {}
    for f in files:
        key = str(f.relative_to(path)) if path.is_dir() else f.name
        if f.suffix == ".png":
            continue  # matplotlib's PNGs carry its version; the numbers behind them are in the JSON
        out[key] = digest_json(f.read_text()) if f.suffix == ".json" else hashlib.sha256(f.read_bytes()).hexdigest()
    return out


def differences(a, b, path: str = "") -> list[str]:
    """Where two JSON documents differ: ``path: a -> b`` (numbers with their relative difference)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b), key=str):
            if k not in a or k not in b:
                out.append(f"{path}/{k}: {'added' if k not in a else 'removed'}")
            else:
                out += differences(a[k], b[k], f"{path}/{k}")
        return out
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in differences(x, y, f"{path}[{i}]")]
    if a == b:
        return []
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        rel = abs(a - b) / max(abs(a), abs(b), 1e-300)
        return [f"{path}: {a!r} -> {b!r} (relative {rel:.1e})"]
    return [f"{path}: {json.dumps(a)[:80]} -> {json.dumps(b)[:80]}"]


class Runner:
    def __init__(self, tree: Path, work: Path):
        self.tree, self.work = tree, work
        self.env = {**os.environ, "PYTHONPATH": str(tree), "TENDON_ID_CACHE": str(work / "cache")}

    def cli(self, *args: str) -> str:
        cmd = [sys.executable, "-m", "tendon_id", *args]
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, cwd=self.work, env=self.env, capture_output=True, text=True)
        took = time.perf_counter() - t0
        print(f"  [{took:6.1f} s] tendon-id {' '.join(args)}", file=sys.stderr, flush=True)
        if proc.returncode != 0:
            raise RuntimeError(f"tendon-id {' '.join(args)} failed ({proc.returncode}):\n{proc.stderr}")
        return proc.stdout


def cases(r: Runner, bench: Path | None) -> dict:
    """Each case's name -> its fingerprint (a digest, or a dict of them)."""
    w = r.work
    sim = "--recipe snake12-paper --protocol posterior-3".split()
    r.cli("simulate", *sim, "--seed", "7", "--frames", "3000", "--out", "train.parquet")
    r.cli("simulate", *sim, "--seed", "8", "--frames", "2000", "--out", "test.parquet")
    yield "simulate/train.parquet", digest_path(w / "train.parquet")
    yield "simulate/test.parquet", digest_path(w / "test.parquet")
    for name, extra in ZOO:
        r.cli("fit", name, "--data", "train.parquet", "--out", f"models/{name}", *extra)
        yield f"fit/{name}", digest_path(w / "models" / name)
        text = r.cli("evaluate", "--model", f"models/{name}", "--data", "test.parquet", "--json")
        yield f"evaluate/{name}", digest_json(text)
    r.cli("calibrate", "--data", "train.parquet", "--model", "capstan-nonsmooth", "--out", "cal/ns")
    yield "calibrate/snake-nonsmooth", digest_path(w / "cal" / "ns")
    r.cli(
        "calibrate", "--data", "train.parquet", "--model", "capstan-contact", "--tying", "per-guide", "--out", "cal/pg"
    )
    yield "calibrate/snake-contact-per-guide", digest_path(w / "cal" / "pg")
    r.cli("calibrate", "--data", "train.parquet", "--model", "capstan-contact", "--posterior", "--out", "cal/post")
    yield "calibrate-posterior/snake-contact", digest_path(w / "cal" / "post")
    r.cli("identifiability", "--data", "train.parquet", "--out", "ident.html", "--json", "ident.json")
    yield "identifiability", digest_path(w / "ident.json")
    r.cli(
        "diagnose", "--data", "train.parquet", "--test", "test.parquet", "--base", "capstan-nonsmooth",
        "--out", "gap.html", "--json", "gap.json",
    )  # fmt: skip
    yield "diagnose/snake", digest_path(w / "gap.json")
    r.cli(
        "diagnose",
        "--data",
        "train.parquet",
        "--base",
        "capstan-contact",
        "--out",
        "gap-cv.html",
        "--json",
        "gap-cv.json",
    )
    yield "diagnose/snake-cv", digest_path(w / "gap-cv.json")
    if bench is None:
        print("  bench files not found: the passage cases are skipped", file=sys.stderr)
        return
    train = [str(bench / f) for f in BENCH_TRAIN]
    test = [str(bench / f) for f in BENCH_TEST]
    m = ["--mapping", "mis-tool-characterization"]
    data = [x for f in train for x in ("--data", f)]
    held = [x for f in test for x in ("--test", f)]
    r.cli("fit", "passage-capstan", *m, *data, "--set", 'blocks=["stick_slip"]', "--out", "models/passage")
    yield "fit/passage-capstan", digest_path(w / "models" / "passage")
    yield (
        "evaluate/passage-capstan",
        digest_json(r.cli("evaluate", "--model", "models/passage", *m, "--data", test[0], "--json")),
    )
    r.cli("info", *m, train[0], "--json")
    yield "info/passage", digest_json(r.cli("info", *m, train[0], "--json"))
    yield "info/snake", digest_json(r.cli("info", "train.parquet", "--json"))
    r.cli(
        "calibrate",
        *m,
        *data,
        "--model",
        "passage-capstan",
        "--blocks",
        "stick_slip,smooth_edge",
        "--out",
        "cal/passage",
    )
    yield "calibrate/passage", digest_path(w / "cal" / "passage")
    r.cli(
        "calibrate", *m, "--data", train[0], "--model", "passage-capstan", "--blocks", "stick_slip", "--posterior",
        "--out", "cal/passage-post",
    )  # fmt: skip
    yield "calibrate-posterior/passage", digest_path(w / "cal" / "passage-post")
    r.cli("diagnose", *m, *data, *held, "--base", "passage-capstan", "--out", "pgap.html", "--json", "pgap.json")
    yield "diagnose/passage", digest_path(w / "pgap.json")


def run(args) -> int:
    tree = Path(args.tree).resolve()
    bench = Path(args.bench) if args.bench else DEFAULT_BENCH
    out: dict = {"tree": str(tree), "cases": {}}
    with tempfile.TemporaryDirectory(prefix="fingerprint-") as tmp:
        r = Runner(tree, Path(tmp))
        for name, fp in cases(r, bench if bench.is_dir() else None):
            out["cases"][name] = fp
            Path(args.out).write_text(json.dumps(out, indent=1, sort_keys=True) + "\n")
            Path(args.out + ".docs.json").write_text(json.dumps(DOCS, sort_keys=True) + "\n")
    print(f"wrote {args.out}: {len(out['cases'])} fingerprints", file=sys.stderr)
    return 0


def _docs(path: str) -> dict:
    p = Path(path + ".docs.json")
    return json.loads(p.read_text()) if p.is_file() else {}


def compare(args) -> int:
    a = json.loads(Path(args.before).read_text())["cases"]
    b = json.loads(Path(args.after).read_text())["cases"]
    docs_a, docs_b = _docs(args.before), _docs(args.after)
    differ = 0
    for name in sorted(set(a) | set(b)):
        if a.get(name) == b.get(name):
            print(f"same     {name}")
            continue
        differ += 1
        print(f"DIFFERS  {name}")
        fa, fb = a.get(name), b.get(name)
        pairs = (
            [(f, (fa or {}).get(f), (fb or {}).get(f)) for f in sorted(set(fa or {}) | set(fb or {}))]
            if (isinstance(fa, dict) or isinstance(fb, dict))
            else [("", fa, fb)]
        )
        for f, da, db in pairs:
            if da == db:
                continue
            print(f"           {f or '(document)'}")
            if da in docs_a and db in docs_b:
                found = differences(docs_a[da], docs_b[db])
                for line in found[: args.lines]:
                    print(f"             {line}")
                if len(found) > args.lines:
                    print(f"             ... and {len(found) - args.lines} more")
    print(f"{len(set(a) | set(b)) - differ} identical, {differ} different")
    return 1 if differ else 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("out")
    r.add_argument("--tree", default=str(ROOT))
    r.add_argument("--bench", default=None)
    c = sub.add_parser("compare")
    c.add_argument("before")
    c.add_argument("after")
    c.add_argument("--lines", type=int, default=8, help="differing fields shown per document")
    args = p.parse_args(argv)
    return run(args) if args.cmd == "run" else compare(args)


if __name__ == "__main__":
    sys.exit(main())
