"""How well a recipe matches the paper's Table II reference rows (proximal measurement).

Usage: python experiments/paper_match.py [--recipe snake12-paper] [--seeds 0 1 2 3 4] [--json FILE]

For each protocol, the RMSE and R^2 of the "proximal measurement" estimate (joint side =
actuator side) at the terminal joint, per tendon and averaged (docs/guide/zoo.rst), over several seeds,
against the paper's Table II (48.522 / 73.075 / 32.699 N; R^2 -0.655 / -2.747 / 0.486).
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

from tendon_id.atomic import write_json_atomic
from tendon_id.datasets import load_recipe
from tendon_id.metrics import tendon_metrics
from tendon_id.sim import simulate

PAPER = {"posterior-3": (48.522, -0.655), "posterior-6": (73.075, -2.747), "planned-paths": (32.699, 0.486)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--recipe", default="snake12-paper")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    recipe = load_recipe(args.recipe)
    t0 = time.perf_counter()
    rows = []
    print(f"recipe {recipe.name}, seeds {args.seeds}, proximal measurement at the terminal joint")
    print(
        f"{'protocol':14s} {'RMSE mean':>9s} {'min':>6s} {'max':>6s} {'paper':>7s} "
        f"{'ratio':>6s} {'R2 mean':>8s} {'paper':>7s}"
    )
    for protocol, (p_rmse, p_r2) in PAPER.items():
        ms = []
        for seed in args.seeds:
            rec = simulate(recipe, protocol, seed=seed).recording
            ms.append(tendon_metrics(rec.actuator[:, -1], rec.terminal))
        rmse = np.array([m["rmse"] for m in ms])
        r2 = np.array([m["r2"] for m in ms])
        ratio = rmse.mean() / p_rmse
        rows.append(
            {
                "protocol": protocol,
                "rmse_mean": rmse.mean(),
                "rmse_min": rmse.min(),
                "rmse_max": rmse.max(),
                "paper_rmse": p_rmse,
                "ratio": ratio,
                "r2_mean": r2.mean(),
                "paper_r2": p_r2,
                "within_1_5": bool(1 / 1.5 <= rmse.min() / p_rmse and rmse.max() / p_rmse <= 1.5),
            }
        )
        print(
            f"{protocol:14s} {rmse.mean():9.1f} {rmse.min():6.1f} {rmse.max():6.1f} {p_rmse:7.1f} "
            f"{ratio:6.2f} {r2.mean():8.2f} {p_r2:7.2f}"
        )
    secs = time.perf_counter() - t0
    print(
        f"every seed within a factor 1.5: {all(r['within_1_5'] for r in rows)}   "
        f"({secs:.1f} s, {platform.machine()}, {platform.python_version()})"
    )
    if args.json:
        write_json_atomic(args.json, {"recipe": recipe.name, "seeds": args.seeds, "rows": rows, "seconds": secs})


if __name__ == "__main__":
    main()
