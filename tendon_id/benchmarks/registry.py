"""Names of the benchmarks and how to run one."""

from __future__ import annotations

from tendon_id.benchmarks.recovery import format_recovery, recovery
from tendon_id.benchmarks.tables import table1, table2
from tendon_id.errors import ConfigError

def _lazy(module: str, func: str):
    def run(**kwargs):
        import importlib

        return getattr(importlib.import_module(module), func)(**kwargs)

    run.__name__ = func
    return run


BENCHMARKS = {
    "table1": table1,
    "table2": table2,
    "recovery": recovery,
    "sweep": _lazy("tendon_id.benchmarks.sweep", "sweep"),
    "latency": _lazy("tendon_id.benchmarks.latency", "latency"),
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
    """The rows as an aligned text table (terminal and intermediate joints)."""
    if result["benchmark"] == "recovery":
        return format_recovery(result)
    if result["benchmark"] == "latency":
        from tendon_id.benchmarks.latency import format_latency

        return format_latency(result)
    if result["benchmark"] == "sweep":
        from tendon_id.benchmarks.sweep import format_sweep

        return format_sweep(result)
    head = f"{'method':22s} {'protocol':15s} {'RMSE [N]':>9s} {'+-sd':>6s} {'R2':>7s} {'MaxErr':>8s} | {'joints RMSE':>11s} {'R2':>7s}"
    reps = result["rows"][0].get("repeats", 1) if result["rows"] else 1
    lines = [f"{result['benchmark']} ({result.get('recipe', '')}, preset {result['preset']}, mean over {reps} splits, "
             f"{result['seconds']:.1f} s)", head, "-" * len(head)]
    for r in result["rows"]:
        t, j = r["terminal"], r["joints"]
        sd = (r.get("terminal_sd") or {}).get("rmse", 0.0)
        js = f"{j['rmse']:11.3f} {j['r2']:7.3f}" if j else f"{'-':>11s} {'-':>7s}"
        lines.append(f"{r['method']:22s} {r['protocol']:15s} {t['rmse']:9.3f} {sd:6.2f} {t['r2']:7.3f} {t['max_error']:8.3f} | {js}")
    return "\n".join(lines)
