"""Scale: time and peak memory of read, fit, diagnose and identifiability, 10^4 to 3.6·10^6 frames (issue 42).

Usage: python perf/bench_scale.py [--sizes 1e4 1e5 1e6 3.6e6] [--families snake bench]
       [--steps read fit diagnose identifiability] [--timeout 900] [--max-gb 8]
       [--workdir DIR] [--json FILE]
       python perf/bench_scale.py --tables RUN.json [RUN.json ...]   (one table of saved runs)

Goals: nothing grows faster than linearly in the frames, and no step's peak memory exceeds
three times the recording's size in float64 (``frames x numeric columns x 8`` bytes).

Data, made once per run at the largest size (each smaller size is its first frames):

* ``snake``: the paper robot (``snake12-paper``, N = 12, 10 Hz), its ``terminal-only``
  protocol simulated in independent 50 000-frame chunks (seed = chunk index; 1000-frame
  trajectories, ids prefixed by the chunk), written without the intermediate truth columns,
  as a robot logs it: 64 numeric columns.
* ``bench``: the real da Vinci bench of ``datasets/mappings/mis-tool-characterization.toml``
  (20 files at 1 kHz, 4·10^5 frames, read from ``../shared/data/real``), cut into 2500-frame
  trajectories and cycled; every copy after the first gets white noise of one sensor count
  (3.98e-5 N m) on both torques and one encoder count on both angles, so that no two
  trajectories are equal: 5 numeric columns.  Where the bench data is absent, synthetic
  passages from the passage model's own physics (``tests/passage_data.py``) stand in, and the
  report says so.

Each recording is one Parquet file (the bench also as three files of a third each, for its
cross-validation by file).  Each step runs in a fresh process, one at a time:

* ``read``: :func:`tendon_id.data.mapping.read_files` (what every command reads with);
* ``fit``: ``tendon-id fit capstan-nonsmooth`` (snake), ``tendon-id fit passage-capstan
  --set blocks='["stick_slip"]'`` (bench: the law with the play operator);
* ``diagnose``: ``tendon-id diagnose --base <the fit's model> --candidates C`` with one
  candidate (``viscoelastic`` on the snake, 3-fold cross-validation by trajectory;
  ``smooth_edge`` is not on the base, so ``velocity_friction`` on the bench, 3-fold
  cross-validation by file): the default tries every candidate (13 on the snake), 13 times
  the work per frame, and fits no size past 10^4 within the timeout on 2 cores;
* ``identifiability``: ``tendon-id identifiability`` (the snake's study; a bench's
  identifiability is its fit's Jacobian correlations, inside ``fit``).

The command steps run through :func:`tendon_id.cli.main` in the child, after the modules
the command imports are loaded: the time is the command's wall and CPU time, reading the
file included; the peak is the child's peak resident memory (``VmHWM``) less its resident
memory just before the command (the interpreter and the imports; reported too).  A step
past ``--timeout`` or ``--max-gb`` is stopped and reported as such, with its peak so far;
larger sizes of that step are then skipped.  Exponents are least-squares slopes of
log(time) and log(net peak) against log(frames) over the sizes measured.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT.parent / "shared" / "data" / "real" / "mis-tool-characterization" / "Tool_4_Maryland_L_2"
SIZES = (10_000, 100_000, 1_000_000, 3_600_000)
STEPS = ("read", "fit", "diagnose", "identifiability")
CHUNK = 50_000  # frames simulated at once (about 0.7 GB of the simulator's working memory)
PIECE = 2_500  # frames of one bench trajectory (2.5 s at 1 kHz): four of them even at 10^4 frames
BASE = {"snake": "capstan-nonsmooth", "bench": "passage-capstan"}
CANDIDATE = {"snake": "viscoelastic", "bench": "stick_slip"}
MODEL = {"snake": ["capstan-nonsmooth"], "bench": ["passage-capstan", "--set", 'blocks=["stick_slip"]']}


# ---- the recordings ------------------------------------------------------------------------------
class Writers:
    """One Parquet writer per size, fed the same stream of frames until each has its frames."""

    def __init__(self, folder: Path, family: str, sizes, meta: dict):
        self.folder, self.family, self.meta, self.sizes = folder, family, meta, sorted(sizes)
        self.done = dict.fromkeys(self.sizes, 0)
        self.open: dict[int, object] = {}

    def path(self, n: int, part: str = "") -> Path:
        return self.folder / f"{self.family}-{n}{part}.parquet"

    def write(self, frame) -> bool:
        """Append ``frame`` (whole trajectories) to every file short of its size; False once all are full."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        from tendon_id.data.io import META_KEY, PARQUET_OPTIONS, meta_json

        table = pa.Table.from_pandas(frame, preserve_index=False)
        table = table.set_column(0, "trajectory", table.column(0).cast(pa.string()))
        table = table.replace_schema_metadata({META_KEY: meta_json(self.meta).encode()})
        opts = {k: v for k, v in PARQUET_OPTIONS.items() if k != "row_group_size"}
        for n in self.sizes:
            need = n - self.done[n]
            if need <= 0:
                continue
            if n not in self.open:
                self.open[n] = pq.ParquetWriter(self.path(n), table.schema, **opts)
            self.open[n].write_table(table.slice(0, need))
            self.done[n] += min(need, table.num_rows)
            if self.done[n] >= n:
                self.open.pop(n).close()
        return any(self.done[n] < n for n in self.sizes)


def make_snake(folder: Path, sizes) -> str:
    """Simulated snake recordings of every size (see the module docstring); what they are."""
    from tendon_id.datasets import load_recipe
    from tendon_id.sim import simulate

    recipe = load_recipe("snake12-paper")
    writers, chunk = None, 0
    while True:
        rec = simulate(recipe, "terminal-only", frames=CHUNK, seed=chunk, progress=False).recording.fitting_view()
        frame = rec.frame.assign(trajectory=f"c{chunk:03d}-" + rec.frame["trajectory"])
        writers = writers or Writers(folder, "snake", sizes, rec.meta)
        chunk += 1
        if not writers.write(frame):
            return f"snake12-paper terminal-only, {chunk} simulated chunks of {CHUNK} frames, no intermediate truth"


def bench_pieces() -> tuple[list, dict, str]:
    """The bench cut into PIECE-frame frames, its metadata, and what it is (real, else synthetic)."""
    files = sorted(BENCH.glob("[0-9][0-9].TXT"))
    if files:
        from tendon_id.data.mapping import load_mapping, read_files
        from tendon_id.datasets import mapping_path

        recs = read_files(files, load_mapping(mapping_path("mis-tool-characterization")))
        what = f"the real bench ({len(files)} files, {sum(r.n_frames for r in recs)} frames at 1 kHz), cycled"
    else:
        sys.path.insert(0, str(ROOT / "tests"))
        from passage_data import tendon_passage

        recs = [tendon_passage(seed, n=20_000, dt=1e-3) for seed in range(20)]
        what = "SYNTHETIC passages (the bench data is absent), cycled"
    pieces = []
    for r in recs:
        f = r.frame
        for k, s in enumerate(range(0, len(f) - PIECE + 1, PIECE)):
            p = f.iloc[s : s + PIECE].reset_index(drop=True)
            pieces.append(p.assign(trajectory=f"{p['trajectory'][0]}-{k}", t=p["t"] - p["t"][0]))
    return pieces, recs[0].meta, what


def make_bench(folder: Path, sizes) -> str:
    """Bench recordings of every size, each also as three files of a third (see the module docstring)."""
    import pandas as pd

    from tendon_id.data.passage import PassageRecording

    pieces, meta, what = bench_pieces()
    rng = np.random.default_rng(0)
    noise = {"input": 3.9811e-5, "output": 3.9811e-5, "position": 2 * np.pi / 8192, "position_out": 2 * np.pi / 4000}
    out = []
    for n in sorted(sizes):
        while len(out) * PIECE < n:
            i, copy = len(out) % len(pieces), len(out) // len(pieces)
            p = pieces[i].assign(trajectory=f"{pieces[i]['trajectory'][0]}-x{copy}")
            if copy:
                p = p.assign(**{c: p[c] + s * rng.standard_normal(PIECE) for c, s in noise.items() if c in p})
            out.append(p)
        k = -(-n // PIECE)  # whole trajectories: n rounded up to a multiple of PIECE
        PassageRecording(pd.concat(out[:k], ignore_index=True), meta).write(folder / f"bench-{n}.parquet")
        for j, part in enumerate(np.array_split(np.arange(k), 3)):
            frame = pd.concat([out[i] for i in part], ignore_index=True)
            PassageRecording(frame, meta).write(folder / f"bench-{n}-part{j}.parquet")
    return f"{what} in {PIECE}-frame trajectories, noise of one count on each copy"


# ---- one step in a fresh process ------------------------------------------------------------------
def status_mb(key: str, pid: int | str = "self") -> float:
    """``VmRSS`` or ``VmHWM`` of a process [MiB], this one by default (Linux's ``/proc``).

    Raises
    ------
    OSError
        Where the process is gone, or the system has no ``/proc`` (the benchmark needs Linux).
    KeyError
        Where the status has no such line.
    """
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1]) / 1024.0
    raise KeyError(f"/proc/{pid}/status has no {key}")


def child(step: str, family: str, argv: list[str]) -> None:
    """Run one step here, print its figures as one JSON line."""
    # The interpreter and what the command imports are the baseline: they do not grow with the data.
    import pyarrow.parquet  # noqa: F401

    import tendon_id.cli  # noqa: F401
    import tendon_id.zoo.passage.family  # noqa: F401
    import tendon_id.zoo.snake.family  # noqa: F401
    from tendon_id.data.mapping import read_files

    if step == "fit":
        import tendon_id.calibration.law  # noqa: F401
        import tendon_id.zoo.passage.fitting  # noqa: F401
    elif step == "diagnose":
        import tendon_id.diagnosis  # noqa: F401
        import tendon_id.report.diagnosis  # noqa: F401
    elif step == "identifiability":
        import tendon_id.identifiability  # noqa: F401
        import tendon_id.report.identifiability  # noqa: F401
    base = status_mb("VmRSS")
    c0, t0 = os.times(), time.perf_counter()
    if step == "import":
        rc = 0
    elif step == "read":
        (rec,) = read_files([Path(argv[0])])
        rc = 0 if rec.n_frames else 1
    else:
        from tendon_id.cli import main

        rc = main(argv)
    seconds, c1 = time.perf_counter() - t0, os.times()
    cpu = (c1.user - c0.user) + (c1.system - c0.system)
    row = {"rc": rc, "seconds": seconds, "cpu_s": cpu, "base_mb": base, "peak_mb": status_mb("VmHWM")}
    if step == "fit" and rc == 0:  # the optimiser's evaluations: a time per evaluation, to compare sizes by
        state = json.loads((Path(argv[argv.index("--out") + 1]) / "model.json").read_text()).get("state", {})
        row["n_eval"] = (state.get("calibration") or {}).get("n_eval")
    print(json.dumps(row))


def run_child(step: str, family: str, argv: list[str], timeout: float, max_gb: float) -> dict:
    """Run ``step`` in a fresh process; stop it past ``timeout`` [s] or ``max_gb`` of resident memory."""
    cmd = [sys.executable, __file__, "--child", step, family, "--", *argv]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    t0 = time.perf_counter()
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen(cmd, stdout=out, stderr=err, env=env)
        stopped, rusage = None, None
        while rusage is None:
            pid, status, ru = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                rusage = ru
                proc.returncode = os.waitstatus_to_exitcode(status)
                break
            try:
                rss = status_mb("VmRSS", proc.pid)
            except (OSError, KeyError):  # it has just exited (gone, or a zombie without memory): wait4 reaps it next
                rss = 0.0
            if time.perf_counter() - t0 > timeout:
                stopped = f"timeout {timeout:.0f} s"
            elif rss > max_gb * 1024:
                stopped = f"over {max_gb:g} GB"
            if stopped:
                proc.kill()
            time.sleep(0.05)
        out.seek(0)
        err.seek(0)
        lines = [s for s in out.read().splitlines() if s.startswith("{")]
        tail = err.read()[-2000:]
    res = {"wall_total_s": time.perf_counter() - t0, "child_peak_mb": rusage.ru_maxrss / 1024.0}
    if stopped or not lines:
        return {**res, "stopped": stopped or f"exit {proc.returncode}: {tail.strip().splitlines()[-1:]}"}
    got = json.loads(lines[-1])
    if got["rc"] != 0:
        return {**res, "stopped": f"exit {got['rc']}: {tail.strip().splitlines()[-1:]}"}
    return {**res, **got, "net_mb": got["peak_mb"] - got["base_mb"]}


def step_argv(step: str, family: str, n: int, data: Path, out: Path) -> list[str] | None:
    """The child's arguments: the file for ``read``, else the command line; None where the step does not apply."""
    rec = data / f"{family}-{n}.parquet"
    if step == "read":
        return [str(rec)]
    if step == "fit":
        return ["fit", *MODEL[family], "--data", str(rec), "--out", str(out / "model")]
    if step == "diagnose":
        files = [rec] if family == "snake" else [data / f"bench-{n}-part{j}.parquet" for j in range(3)]
        args = ["diagnose", "--base", BASE[family], "--candidates", CANDIDATE[family], "--out", str(out / "d.html")]
        return [*args, *[a for f in files for a in ("--data", str(f))]]
    if step == "identifiability" and family == "snake":
        return ["identifiability", "--data", str(rec), "--out", str(out / "i.html")]
    return None


# ---- the table ------------------------------------------------------------------------------------
def numeric_columns(path: Path) -> int:
    """Numeric columns of a recording file (all but ``trajectory``)."""
    import pyarrow.parquet as pq

    return sum(1 for f in pq.read_schema(path) if f.name != "trajectory")


def exponent(rows: list[dict], key: str) -> float | None:
    """Slope of log(``key``) against log(frames) over the rows that have it (None under two)."""
    pts = [(r["frames"], r[key]) for r in rows if r.get(key) and r[key] > 0]
    if len(pts) < 2:
        return None
    x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.polyfit(x, y, 1)[0])


def table(rows: list[dict], exps: dict) -> str:
    """The scale table in markdown: one row per step and size, then one per curve's exponents."""
    head = "| family | step | frames | recording MiB | wall s | CPU s | base MiB | net peak MiB | peak / recording |"
    lines = [head, "|" + "---|" * 9]
    for r in rows:
        if "stopped" in r:
            what = r["stopped"]
            peak = f"> {r['child_peak_mb']:.0f} (gross)" if r.get("child_peak_mb") else "-"
            lines.append(
                f"| {r['family']} | {r['step']} | {r['frames']:,} | {r['rec_mb']:.1f} | {what} | | | {peak} | |"
            )
            continue
        lines.append(
            f"| {r['family']} | {r['step']} | {r['frames']:,} | {r['rec_mb']:.1f} | {r['seconds']:.2f} | "
            f"{r['cpu_s']:.2f} | {r['base_mb']:.0f} | {r['net_mb']:.0f} | {r['net_mb'] / r['rec_mb']:.2f} |"
        )
    lines += [
        "",
        "| family | step | exponent of wall time | of CPU time | of net peak memory | sizes "
        "| CPU, two largest | memory, two largest |",
        "|" + "---|" * 8,
    ]
    for (fam, step), e in exps.items():
        keys = ("seconds", "cpu_s", "net_mb", "cpu_s_top", "net_mb_top")
        f = [("-" if e.get(k) is None else f"{e[k]:.2f}") for k in keys]
        lines.append(f"| {fam} | {step} | {f[0]} | {f[1]} | {f[2]} | {e['sizes']} | {f[3]} | {f[4]} |")
    return "\n".join(lines)


def loadavg() -> str:
    return Path("/proc/loadavg").read_text().split(" ", 3)[:3].__str__()


def measure(args, data: Path) -> list[dict]:
    """Every step of every family at every size, one fresh process at a time."""
    rows = []
    for family in args.families:
        cols = numeric_columns(data / f"{family}-{min(args.sizes)}.parquet")
        for step in args.steps:
            stop = None
            for n in sorted(args.sizes):
                with tempfile.TemporaryDirectory() as out:
                    argv = step_argv(step, family, n, data, Path(out))
                    if argv is None:
                        break
                    row = {"family": family, "step": step, "frames": n, "rec_mb": n * cols * 8 / 2**20}
                    row["load_before"] = loadavg()
                    if stop:
                        rows.append({**row, "stopped": f"not run ({stop} at a smaller size)"})
                        continue
                    row.update(run_child(step, family, argv, args.timeout, args.max_gb))
                row["load_after"] = loadavg()
                rows.append(row)
                stop = row.get("stopped")
                shown = row.get("stopped") or f"{row['seconds']:.2f} s, net peak {row['net_mb']:.0f} MiB"
                print(f"{family:5s} {step:15s} {n:>9,} frames: {shown}  (load {row['load_after']})", flush=True)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=float, nargs="+", default=list(SIZES))
    ap.add_argument("--families", nargs="+", choices=("snake", "bench"), default=["snake", "bench"])
    ap.add_argument("--steps", nargs="+", choices=STEPS, default=list(STEPS))
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds one step may take")
    ap.add_argument("--max-gb", type=float, default=8.0, help="resident memory one step may reach [GiB]")
    ap.add_argument("--workdir", default=None, help="keep the recordings here (made where missing)")
    ap.add_argument("--json", default=None)
    ap.add_argument("--tables", nargs="+", metavar="JSON", help="print one table of these saved runs, and stop")
    ap.add_argument("--child", nargs=2, metavar=("STEP", "FAMILY"), help=argparse.SUPPRESS)
    ap.add_argument("rest", nargs="*", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child(*args.child, args.rest)
        return 0
    if args.tables:  # several runs (a family or a step each) as one table
        rows = [r for f in args.tables for r in json.loads(Path(f).read_text())["rows"]]
        print(table(rows, exponents(rows)))
        return 0
    args.sizes = sorted({int(s) for s in args.sizes})
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(args.workdir or tmp)
        data.mkdir(parents=True, exist_ok=True)
        made = {}
        for family, make in (("snake", make_snake), ("bench", make_bench)):
            missing = [n for n in args.sizes if not (data / f"{family}-{n}.parquet").exists()]
            if family in args.families and missing:
                t0 = time.perf_counter()
                made[family] = f"{make(data, missing)} ({time.perf_counter() - t0:.0f} s)"
                print(f"{family}: {made[family]}", flush=True)
        imports = run_child("import", "-", [], args.timeout, args.max_gb)
        if "stopped" in imports:  # nothing to measure against: say why and stop
            raise SystemExit(f"importing the toolkit failed in a fresh process: {imports['stopped']}")
        print(f"import only: {imports['base_mb']:.0f} MiB resident", flush=True)
        rows = measure(args, data)
    exps = exponents(rows)
    text = table(rows, exps)
    print(text)
    if args.json:
        from tendon_id.atomic import write_json_atomic

        out = {
            "rows": rows,
            "exponents": [{"family": f, "step": s, **e} for (f, s), e in exps.items()],
            "data": made,
            "import_only": imports,
            "cpu_count": os.cpu_count(),
            "machine": f"{platform.machine()}, {platform.python_version()}",
            "table": text,
        }
        write_json_atomic(Path(args.json), out)
    return 0


def exponents(rows: list[dict]) -> dict:
    """Each curve's exponents, keyed by ``(family, step)``."""
    exps = {}
    for key in dict.fromkeys((r["family"], r["step"]) for r in rows):
        sub = [r for r in rows if (r["family"], r["step"]) == key and "stopped" not in r]
        exps[key] = {k: exponent(sub, k) for k in ("seconds", "cpu_s", "net_mb")}
        # The fixed cost (imports, start-up) flattens the fit over all sizes; the growth where
        # the frames dominate is the slope between the two largest sizes measured.
        exps[key].update({f"{k}_top": exponent(sub[-2:], k) for k in ("cpu_s", "net_mb")})
        exps[key]["sizes"] = ", ".join(f"{r['frames']:.0e}" for r in sub)
    return exps


if __name__ == "__main__":
    raise SystemExit(main())
