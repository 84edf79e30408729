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


#: The loops of a step test, by number.
LOOPS = {1: "step", 2: "return"}


def _mean_settle(rows: list[dict], estimator: str, regime: str) -> float:
    """Mean settling time over both loops [s]; infinite when a loop never settles."""
    vals = [r["settle_s"] for r in rows if r["estimator"] == estimator and r["regime"] == regime]
    return float("inf") if any(v is None for v in vals) else float(np.mean(vals))


def _mean_rms(rows: list[dict], estimator: str, regime: str) -> float:
    """Mean RMS tracking error over both loops [deg]."""
    return float(np.mean([r["rms_deg"] for r in rows if r["estimator"] == estimator and r["regime"] == regime]))


def mean_why(rows: list[dict], estimator: str, regime: str, key: str) -> float:
    """Mean of ``why[key]`` over both loops of one estimator and regime."""
    return float(np.mean([r["why"][key] for r in rows if r["estimator"] == estimator and r["regime"] == regime]))


def _unsettled(rows: list[dict], estimator: str, regime: str) -> str:
    """How often an estimator that did not always settle failed to: ``"never settles"``, or per seed and loop."""
    mine = [r for r in rows if r["estimator"] == estimator and r["regime"] == regime]
    runs = sum(r["seeds"] for r in mine)
    missed = sum(r["seeds"] - r.get("settle_s_reached", 0 if r["settle_s"] is None else r["seeds"]) for r in mine)
    if missed >= runs:
        return "never settles"
    return f"it does not settle within the test in {missed} of its {runs} runs, seeds times step and return"


def _s(v: float) -> str:
    return "never settles" if not np.isfinite(v) else f"{v:.1f} s"


def _slowest_loop(rows, regime, names, worst, open_loop) -> list[tuple[str, str]]:
    """A sentence when one loop of another estimator settles slower than the slowest on average."""
    timed = [r for r in rows if r["regime"] == regime and r["estimator"] in names]
    slow = max(timed, key=lambda r: np.inf if r["settle_s"] is None else r["settle_s"])
    if slow["estimator"] == worst:
        return []
    e, k = slow["estimator"], slow["loop"]
    same = [r for r in timed if r["loop"] == k and r["estimator"] != e]
    fast = min(same, key=lambda r: np.inf if r["settle_s"] is None else r["settle_s"])
    text = f"{e} has the slowest single settling, {_s(slow['settle_s'] or np.inf)} on the {LOOPS[k]}; "
    mine, theirs = slow["why"]["torque_error_nm"], fast["why"]["torque_error_nm"]
    if mine <= 1.1 * theirs:
        text += (
            f"its torque error there ({mine:.2f} N m) is no larger than {fast['estimator']}'s ({theirs:.2f} N m), "
            f"so the estimate's error does not explain it: its angle lingers near the edge of the ±0.5° band "
            f"(RMS {slow['rms_deg']:.2f}°), which one seed may not show again."
        )
    else:
        text += f"its torque error there is {mine:.2f} N m against {theirs:.2f} N m for {fast['estimator']}."
    return [(text + _open_loop_note(e, open_loop, names), "plain")]


def _open_loop_note(e: str, open_loop, names) -> str:
    """A sentence when ``e``, slow in the loop, was the most accurate open loop; else nothing."""
    if not open_loop or e not in open_loop or open_loop[e] > min(open_loop.get(n, np.inf) for n in names):
        return ""
    return (
        f" {e} was the most accurate open loop ({open_loop[e]:.1f} N RMSE at the intermediate joints): an "
        "accuracy averaged over every joint and tendon does not rank the torque errors at the few joints a step "
        "moves, nor how an estimate's error feeds back through the loop."
    )


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
        rms = {e: _mean_rms(rows, e, regime) for e in names}
        has_oracle = "oracle" in {r["estimator"] for r in rows}
        if has_oracle and not np.isfinite(_mean_settle(rows, "oracle", regime)):
            out.append(
                (
                    f"{regime}: even the true tensions (oracle) do not settle in every loop "
                    f"({_unsettled(rows, 'oracle', regime)}). The controller's gains were tuned with the oracle on "
                    "other seeds (experiments/tune_closed_loop.py); a settling time is all or nothing at the band's "
                    "edge, so read the RMS errors too.",
                    "warning",
                )
            )
        # Settled in every loop first (fastest first), then the rest by their RMS tracking error.
        ranked = sorted(names, key=lambda e: (settle[e], rms[e]))
        best, worst = ranked[0], ranked[-1]
        if np.isfinite(settle[best]):
            text = f"{regime}: {best} settles fastest ({_s(settle[best])} on average over the step and the return)"
            if has_oracle:
                text += f", against {_s(_mean_settle(rows, 'oracle', regime))} with the true tensions (oracle)"
            if worst != best:
                slowest = _s(settle[worst]) if np.isfinite(settle[worst]) else _unsettled(rows, worst, regime)
                text += f"; {worst} settles slowest ({slowest})."
            else:
                text += "."
        else:
            text = f"{regime}: no estimator settles in every loop; {best} tracks best (RMS {rms[best]:.2f}°)"
            if worst != best:
                text += f", {worst} worst ({rms[worst]:.2f}°)"
            if has_oracle:
                text += f", against {_mean_rms(rows, 'oracle', regime):.2f}° with the true tensions (oracle)"
            text += "."
        out.append((text, "verdict"))
        if worst != best:
            tq = {e: mean_why(rows, e, regime, "torque_error_nm") for e in (best, worst)}
            why = (
                f"Why: what the controller feels is the joint torque an estimate implies; at the stepped joints "
                f"{worst}'s is off by {tq[worst]:.2f} N m (RMS) against {tq[best]:.2f} N m for {best}"
            )
            if all("load_error_nm" in r["why"] for r in rows):
                load = {e: mean_why(rows, e, regime, "load_error_nm") for e in (best, worst)}
                why += (
                    f", and the pass-through load its intermediate estimates imply by {load[worst]:.2f} N m against "
                    f"{load[best]:.2f} N m"
                )
            out.append((why + "." + _open_loop_note(worst, open_loop, names), "plain"))
        if np.isfinite(settle[best]):
            out += _slowest_loop(rows, regime, names, worst, open_loop)
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
