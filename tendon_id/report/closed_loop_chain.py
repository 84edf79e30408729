"""What intermediate accuracy buys: closed-loop settle and RMS against the intermediate-joint error.

On the plant where every tendon crossing a joint pulls on it (:doc:`/guide/closed_loop`), the
controller feeds forward the moments of the distal sets' tendons at each joint they pass
through, at the estimator's tensions there ``T_hat[k, j]`` (``k < j``).  Those are the tensions
terminal-only supervision never sees.  This section plots, per regime and loop, each
estimator's settling time and RMS tracking error against the RMSE of those intermediate
estimates, measured in the same closed-loop runs (mean over seeds).
"""

from __future__ import annotations

from tendon_id.report.closed_loop_lead import mean_why
from tendon_id.report.html import pyplot

#: A loop that never settled is drawn at this height above the slowest that did, marked "never".
_NEVER_MARGIN = 1.15


def _points(rows: list[dict], regime: str, loop: int) -> list[tuple[str, float, float | None, float]]:
    """(estimator, intermediate RMSE [N], settle [s] or None, RMS [deg]) of one regime and loop."""
    return [
        (r["estimator"], r["why"]["intermediate_rmse_n"], r["settle_s"], r["rms_deg"])
        for r in rows
        if r["regime"] == regime and r["loop"] == loop and "intermediate_rmse_n" in r["why"]
    ]


def chain_figure(rows: list[dict], colours: dict):
    """Settle [s] and RMS [deg] against intermediate-joint RMSE [N]: one marker per estimator, regime and loop.

    Returns None where the rows carry no intermediate error (a result from before the chain was measured).
    """
    regimes = list(dict.fromkeys(r["regime"] for r in rows))
    if not any(_points(rows, g, loop) for g in regimes for loop in (1, 2)):
        return None
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.2))
    markers = {1: "o", 2: "s"}
    fills = dict(zip(regimes, ("full", "none", "left", "right")))
    settled = [p[2] for g in regimes for loop in (1, 2) for p in _points(rows, g, loop) if p[2] is not None]
    never_at = _NEVER_MARGIN * max(settled) if settled else 1.0
    for regime in regimes:
        for loop in (1, 2):
            for name, x, settle, rms in _points(rows, regime, loop):
                style = dict(
                    color=colours.get(name, "tab:olive"),
                    marker=markers[loop],
                    fillstyle=fills[regime],
                    ms=8,
                    ls="none",
                )
                axes[0].plot(x, never_at if settle is None else settle, **style)
                axes[1].plot(x, rms, **style)
    axes[0].axhline(never_at, color="0.6", ls=":", lw=0.8)
    axes[0].text(axes[0].get_xlim()[0], never_at, " never settled", va="bottom", fontsize=8, color="0.4")
    axes[0].set_ylabel("settling time on ±0.5° [s]")
    axes[1].set_ylabel("RMS tracking error [°]")
    for ax in axes:
        ax.set_xlabel("intermediate-joint RMSE, T[k, j] for k < j [N]")
        ax.grid(alpha=0.3)
    handles = [
        plt.Line2D([], [], color=colours.get(n, "tab:olive"), marker="o", ls="none", label=n)
        for n in dict.fromkeys(r["estimator"] for r in rows)
    ]
    handles += [plt.Line2D([], [], color="k", marker=markers[lp], ls="none", label=f"loop {lp}") for lp in (1, 2)]
    handles += [plt.Line2D([], [], color="k", marker="o", fillstyle=fills[g], ls="none", label=g) for g in regimes]
    # Beside the axes, not over them: the points fill both panels.
    fig.legend(handles=handles, fontsize=8, loc="center left", bbox_to_anchor=(0.86, 0.5), frameon=False)
    fig.suptitle("What intermediate accuracy buys: the same closed-loop runs", fontsize=11)
    fig.tight_layout(rect=(0, 0, 0.86, 1))
    return fig


def chain_rows(rows: list[dict]) -> list[list[str]]:
    """Table rows: estimator and regime, intermediate RMSE and load error, then settle and RMS per loop."""
    out = []
    keys = list(dict.fromkeys((r["regime"], r["estimator"]) for r in rows if "intermediate_rmse_n" in r["why"]))
    for regime, name in sorted(keys, key=lambda k: (k[0], mean_why(rows, k[1], k[0], "intermediate_rmse_n"))):
        loops = {r["loop"]: r for r in rows if (r["regime"], r["estimator"]) == (regime, name)}
        cells = [regime, name, f"{mean_why(rows, name, regime, 'intermediate_rmse_n'):.1f}"]
        cells.append(f"{mean_why(rows, name, regime, 'load_error_nm'):.3f}")
        for loop in (1, 2):
            r = loops.get(loop)
            cells.append("-" if r is None else ("never" if r["settle_s"] is None else f"{r['settle_s']:.2f}"))
            cells.append("-" if r is None else f"{r['rms_deg']:.2f}")
        out.append(cells)
    return out


CHAIN_HEADER = [
    "regime",
    "estimator",
    "intermediate RMSE [N]",
    "pass-through load error [N m]",
    "settle, loop 1 [s]",
    "RMS, loop 1 [°]",
    "settle, loop 2 [s]",
    "RMS, loop 2 [°]",
]
