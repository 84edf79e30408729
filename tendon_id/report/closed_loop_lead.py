"""The first screen of the closed-loop page: who settles fastest and slowest, why, and how far to trust it."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

#: What the table's terms mean, said once on the page.
TERMS = (
    "Loop 1 is the step out (0 to the commanded amplitude) and loop 2 the return (back to 0). "
    "Stick is the share of the stepped sets' guide passages whose play operator is in stick "
    "(static friction: the tendon does not slide there), over the loop."
)


def _mean_settle(rows: list[dict], estimator: str, regime: str) -> float:
    """Mean settling time over both loops [s]; infinite when a loop never settles."""
    vals = [r["settle_s"] for r in rows if r["estimator"] == estimator and r["regime"] == regime]
    return float("inf") if any(v is None for v in vals) else float(np.mean(vals))


def _mean_why(rows: list[dict], estimator: str, regime: str, key: str) -> float:
    return float(np.mean([r["why"][key] for r in rows if r["estimator"] == estimator and r["regime"] == regime]))


def _s(v: float) -> str:
    return "never settles" if not np.isfinite(v) else f"{v:.1f} s"


def lead_sentences(result: Mapping, open_loop: Mapping[str, float] | None = None) -> list[tuple[str, str]]:
    """``(text, tone)`` pairs for :meth:`HtmlPage.lead`, per regime, from Table III's rows.

    Parameters
    ----------
    result : mapping
        :func:`~tendon_id.benchmarks.table3.closed_loop_tests`'s result.
    open_loop : mapping of estimator name to RMSE [N], optional
        The estimators' open-loop intermediate-joint RMSE (the demo's summary page), to say where
        the closed-loop ranking differs from it.
    """
    rows = result["rows"]
    out = []
    for regime in dict.fromkeys(r["regime"] for r in rows):
        names = [e for e in dict.fromkeys(r["estimator"] for r in rows if r["regime"] == regime) if e != "oracle"]
        if not names:
            continue
        settle = {e: _mean_settle(rows, e, regime) for e in names}
        ranked = sorted(names, key=lambda e: settle[e])
        best, worst = ranked[0], ranked[-1]
        text = f"{regime}: {best} settles fastest ({_s(settle[best])} on average over the step and the return)"
        if "oracle" in {r["estimator"] for r in rows}:
            text += f", against {_s(_mean_settle(rows, 'oracle', regime))} with the true tensions (oracle)"
        text += f"; {worst} settles slowest ({_s(settle[worst])})." if worst != best else "."
        out.append((text, "verdict"))
        if worst != best:
            tq = {e: _mean_why(rows, e, regime, "torque_error_nm") for e in (best, worst)}
            why = (
                f"Why: what the controller feels is the joint torque an estimate implies; at the stepped joints "
                f"{worst}'s is off by {tq[worst]:.2f} N m (RMS) against {tq[best]:.2f} N m for {best}."
            )
            if open_loop and worst in open_loop and open_loop[worst] <= min(open_loop.get(e, np.inf) for e in names):
                why += (
                    f" {worst} was the most accurate open loop (intermediate joints, {open_loop[worst]:.1f} N RMSE): "
                    "an accuracy averaged over every joint and tendon does not rank the torque errors at the few "
                    "joints a step moves, nor how an estimate's error feeds back through the loop."
                )
            out.append((why, "plain"))
    seeds = max((r["seeds"] for r in rows), default=1)
    out.append(
        (
            (
                "How far to trust it: one seed (one step direction and sensor noise draw); differences of a second "
                "or less may not hold over seeds. The full table over seeds is tendon-id benchmark table3."
            )
            if seeds == 1
            else f"Mean ± sd over {seeds} seeds.",
            "plain",
        )
    )
    return out
