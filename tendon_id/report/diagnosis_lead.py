"""The first screen of the diagnosis page: the verdict, how far to trust it, and the simulator's truth beside it.

On simulated data the toolkit knows what the simulator put in (:attr:`DiagnosisResult.truth`),
so the page can say whether the verdict found it; on real data it says what the verdict rests on.
"""

from __future__ import annotations

from tendon_id.diagnosis.result import DiagnosisResult
from tendon_id.report.truth import effect_words, truth_names, truth_sentence

#: Candidates that refine an effect of the simulator under another name (the stick–slip edge's width, the
#: elastic tendon that drives the slip).
REFINES = {"smooth_edge": "stick_slip", "elastic_tendon": "stick_slip"}


def percent(x: float) -> str:
    """A share as a whole percentage, never "-0%"."""
    return f"{round(100 * x) + 0}%"


def in_base(result: DiagnosisResult) -> set[str]:
    """The effects the base already has (the diagnosis skipped them as candidates)."""
    return {e for e, why in result.skipped.items() if "base" in why}


def truth_rows(result: DiagnosisResult) -> list[list[object]]:
    """One row per effect of the truth or the library: in the truth, in the base, as a candidate, named."""
    truth = truth_names(result.truth)
    base = in_base(result)
    cands = {c.effect: c for c in result.candidates}
    rows = []
    for effect in sorted(truth | set(cands) | base, key=lambda e: (e not in truth, e)):
        c = cands.get(effect)
        rows.append(
            [
                effect,
                "yes" if effect in truth else ("(refines " + REFINES[effect] + ")" if effect in REFINES else "no"),
                "yes" if effect in base else "no",
                "-" if c is None else percent(c.gap_closed) + (" (at a bound)" if c.at_bound else ""),
                "yes" if effect in result.verdict.effects else "no",
            ]
        )
    return rows


def lead_sentences(result: DiagnosisResult) -> list[tuple[str, str]]:
    """``(text, tone)`` pairs for :meth:`HtmlPage.lead`: verdict, warning, truth, trust."""
    u, v = result.unit, result.verdict
    out = [
        (
            f"Verdict on {result.base} (held-out RMSE {result.base_rmse:.3g} {u}, noise floor "
            f"{result.noise_floor:.3g} {u}): {v.text}.",
            "verdict",
        )
    ]
    best = result.candidates[0] if result.candidates else None
    if best is not None and best.at_bound:
        every = "every parameter" if set(best.at_bound) >= set(best.params) else ", ".join(best.at_bound)
        out.append(
            (
                f"The best candidate, {best.effect}, closes {best.gap_closed:.0%} of the gap only with {every} on the "
                "edge of its plausible range: it stands in for something outside the library. Do not read its "
                "fitted values as the robot's.",
                "warning",
            )
        )
    if result.truth is None:
        out.append(
            (
                "How far to trust it: this is real data, so no truth is known; the verdict rests on held-out error "
                f"({result.validation}) and on the candidates in the library. An effect outside the library can only "
                "show as 'unexplained'.",
                "plain",
            )
        )
        return out
    out.append((truth_sentence(result.truth), "truth"))
    truth = truth_names(result.truth)
    missing = sorted(truth - in_base(result))
    closed = {c.effect: c.gap_closed for c in result.candidates}
    named = set(v.effects)
    if named:
        wrong = sorted(named - truth)
        trust = (
            f"Against that truth the verdict is right: {effect_words(sorted(named))} is in the truth and not in the "
            "base."
            if not wrong
            else f"Against that truth the verdict is wrong: {effect_words(wrong)} is not in the truth."
        )
    elif v.kind == "none":
        trust = (
            "Against that truth this is right: the base lacks nothing the truth has."
            if not missing
            else f"Against that truth this misses {effect_words(missing)}, which the base lacks."
        )
    else:
        trust = "Against that truth, the diagnosis rightly names nothing outside it"
        trust += (
            f", but it does not find what the base lacks either: {effect_words(missing)}"
            + (
                " (as candidates they close "
                + ", ".join(f"{percent(closed[e])} for {e}" for e in missing if e in closed)
                + ")"
                if any(e in closed for e in missing)
                else ""
            )
            + "."
            if missing
            else "."
        )
    out.append((trust, "plain"))
    return out
