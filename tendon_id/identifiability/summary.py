"""What a reader must know first about an identifiability study, in a few plain sentences (and its tables).

:func:`lead_sentences` gives the verdict and how far to trust it, any warning that changes how
the numbers read (a misspecified structure: its numbers are the fit's, not the robot's), the
simulator's truth beside the finding where the data has one, and the advice only with its
check's verdict.  The report puts them under its title (:meth:`tendon_id.report.html.HtmlPage.lead`)
and the JSON under ``summary``, in this order: a warning first, before any number it qualifies.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tendon_id.report.truth import effect_words

#: An :class:`~tendon_id.identifiability.analysis.IdentifiabilityResult`; not imported, since the
#: result's module imports this one for its JSON's ``summary``.
IdentifiabilityResult = Any


def span(values, unit: str = "", digits: int = 2) -> str:
    """``[40.2, 44.8, 46.8]`` -> ``"40–47 N"``; equal values once (``"1.0 N"``)."""
    lo, hi = float(np.min(values)), float(np.max(values))
    f = lambda v: f"{v:.{digits}g}" if abs(v) >= 10 ** (digits - 1) else f"{v:.{digits - 1}f}"  # noqa: E731
    a, b = f(lo), f(hi)
    text = a if a == b else f"{a}–{b}"
    return f"{text} {unit}".rstrip()


def fitted_mu0(result: IdentifiabilityResult) -> list[tuple[float, float]]:
    """Posterior mean and sd of the tied law's ``mu(0) = A + B`` per tendon [-]."""
    post = result.studies["tied"].posterior_summary()
    m = result.studies["tied"].problem.n_tendons
    return [(post[f"mu0_t{i + 1}"]["mean"], post[f"mu0_t{i + 1}"]["sd"]) for i in range(m)]


def _numbers(values, fmt: str = ".3f") -> str:
    return ", ".join(f"{v:{fmt}}" for v in values)


def pct(x: float) -> str:
    """A fraction as a whole percentage, never ``-0 %``."""
    return f"{round(100 * x) + 0:.0f} %"


def _pct(x: float) -> str:
    """A band change as the reader sees it: a shrinkage of 0.63 -> ``"63 % narrower"``, of -0.1 -> ``"10 % wider"``."""
    return f"{100 * abs(x):.0f} % {'narrower' if x >= 0 else 'wider'}"


def lead_sentences(result: IdentifiabilityResult) -> list[dict]:
    """The page's lead: ``{"tone", "text"}`` per sentence, in reading order.

    Tones are those of :meth:`tendon_id.report.html.HtmlPage.lead`: ``warning`` (first, when the
    structure is misspecified), ``verdict``, ``truth`` (simulated data) and the advice
    (``warning`` where the check contradicts it, else ``plain``).
    """
    mis = result.misspecification
    tied, per = result.studies["tied"], result.studies["per-guide"]
    cov = result.coverage
    coverage = None if cov is None else float(np.mean(cov["tied"][1:-1]))
    residual = span(mis["residual_sigma_n"], "N")
    noise = f"{mis['nominal_noise_n']:g} N"
    mu0 = fitted_mu0(result)
    out = []
    if mis["misspecified"]:
        text = (
            f"The {result.model_name} structure does not explain this data (terminal residual {residual} against "
            f"{noise} of load-cell noise): every number below is the misspecified fit's, not the robot's."
        )
        if coverage is not None:
            text += f" Its 95 % band holds the true intermediate tensions in only {100 * coverage:.0f} % of frames."
        out.append({"tone": "warning", "text": text})
        out.append(
            {
                "tone": "verdict",
                "text": f"The terminal-only data pin the fit's mu(0) = A + B per tendon (tied law, rank "
                f"{tied.rank}/{tied.n_params}) but not the per-guide law (rank {per.rank} of {per.n_params}); "
                "because the structure is wrong, a tight fitted value is not a tight estimate of the robot's friction.",
            }
        )
    else:
        text = (
            f"The {result.model_name} structure explains this data (terminal residual {residual} against {noise} of "
            f"load-cell noise): the terminal-only data determine mu(0) = A + B per tendon (tied law, rank "
            f"{tied.rank}/{tied.n_params}, fitted {_numbers(m for m, _ in mu0)}, sd at most "
            f"{max(s for _, s in mu0):.2g}), not A and B apart, nor the per-guide law "
            f"(rank {per.rank} of {per.n_params})."
        )
        if coverage is not None:
            text += f" Its 95 % band holds the true intermediate tensions in {100 * coverage:.0f} % of frames."
        out.append({"tone": "verdict", "text": text})
    law = result.truth_law
    if law is not None:
        fitted = "the misspecified fit gives" if mis["misspecified"] else "the fit gives"
        share = np.mean([m for m, _ in mu0]) / np.mean(law["mu0"])
        text = (
            f"Simulator truth ({law['recipe']}): mu(0) = A + B = {_numbers(law['mu0'], '.2f')} "
            f"for tendons 1–{len(law['mu0'])}, "
            f"the same at every guide; {fitted} {_numbers(m for m, _ in mu0)}"
            + (f", {100 * share:.0f} % of the truth." if abs(share - 1) > 0.1 else ".")
        )
        if law["effects"]:
            text += f" The simulator adds {effect_words(law['effects'], law.get('effect_params'))} to that law."
        out.append({"tone": "truth", "text": text})
    out.append(advice_sentence(result))
    return out


def _rmse_change(v: dict, key: str, result: IdentifiabilityResult) -> str:
    base = None if result.advice_baseline is None else result.advice_baseline.get("rmse_n")
    if base is None or v.get(key) is None:
        return ""
    return f", RMSE against the truth {base:.2g} → {v[key]:.2g} N"


def advice_sentence(result: IdentifiabilityResult) -> dict:
    """The advice on which joint to instrument, only with its check's verdict (``{"tone", "text"}``).

    A joint is named to instrument only where the check against the truth confirms the
    linearised advice (:func:`~tendon_id.identifiability.advice.judge_advice`); where it does not,
    the sentence says so and names the joint the check found best; without truth the advice is
    given as unchecked.
    """
    v = result.advice_verdict
    j, expected = v["linearised_joint"], v["expected_shrinkage"]
    if v["status"] == "unchecked":
        why = "no intermediate truth to check it against" if result.truth is None else "the check was not run"
        return {
            "tone": "plain",
            "text": f"Unchecked linearised advice ({why}): instrumenting joint {j} is expected to make the "
            f"per-guide band {_pct(expected)}.",
        }
    best = v["measured_best_joint"]
    if v["status"] == "confirmed":
        text = (
            f"Instrument joint {j} next: the check against the simulator truth confirms it (per-guide band "
            f"{_pct(v['measured_shrinkage'])} measured, {pct(expected)} expected"
            f"{_rmse_change(v, 'rmse_n', result)})."
        )
        if best != j:
            text += f" The check's best was joint {best} ({_pct(v['measured_best_shrinkage'])})."
        return {"tone": "plain", "text": text}
    text = (
        f"No joint to instrument is advised: the linearised advice (joint {j}, per-guide band expected "
        f"{_pct(expected)}) was not confirmed by the check against the simulator truth (measured "
        f"{_pct(v['measured_shrinkage'])})."
    )
    if best != j:
        text += (
            f" The check found joint {best} best: band {_pct(v['measured_best_shrinkage'])} "
            f"({pct(v['measured_best_expected_shrinkage'])} expected)"
            f"{_rmse_change(v, 'measured_best_rmse_n', result)}."
        )
    return {"tone": "warning", "text": text}


def trust_sentences(result: IdentifiabilityResult) -> list[str]:
    """The residual against the load cells' noise and, with truth, the bands' coverage of it."""
    mis = result.misspecification
    res = ", ".join(f"{s:.2f}" for s in mis["residual_sigma_n"])
    cov = result.coverage
    noise, ratio = f"{mis['nominal_noise_n']:g} N", f"{mis['threshold_ratio']:g}"
    if mis["misspecified"]:
        out = [
            f"Misspecified: the terminal residual corresponds to {res} N of noise "
            f"(tendons 1–{len(mis['residual_sigma_n'])}) against the load "
            f"cells' {noise} (threshold: {ratio} times). The {result.model_name} structure does not explain this "
            "data, so its estimates, sds and bands describe the misspecified fit, not the robot; "
            + (
                "the coverage below says how far off they are."
                if cov is not None
                else "an unmodelled effect is likely (see `tendon-id diagnose`)."
            )
        ]
    else:
        out = [
            f"The residual ({res} N) matches the load cells' {noise} noise (within {ratio} times): no sign of "
            "misspecification."
        ]
    if cov is not None:
        tied, per = cov["tied"][1:-1], cov["per-guide"][1:-1]
        out.append(
            f"The simulator truth lies inside the tied 95 % band for {100 * np.mean(tied):.1f} % of frames "
            f"(worst joint {100 * np.min(tied):.1f} %), inside the per-guide band for {100 * np.mean(per):.1f} % "
            "(intermediate joints; nominal 95 %)."
        )
    return out


def tendon_sentences(result: IdentifiabilityResult, fitted: str = "fitted") -> list[str]:
    """Per tendon: the fitted mu(0), A and B with their posterior sds, beside the truth where known."""
    tied = result.studies["tied"]
    post = tied.posterior_summary()
    law = result.truth_law
    out = []
    for i in range(tied.problem.n_tendons):
        a, b, m = post[f"A_t{i + 1}"], post[f"B_t{i + 1}"], post[f"mu0_t{i + 1}"]
        tr = (lambda k: f" (truth {law[k][i]:.2f})") if law else (lambda k: "")  # noqa: E731
        off = f", {abs(law['mu0'][i] - m['mean']) / m['sd']:.0f} sd from the truth" if law and m["sd"] > 0 else ""
        out.append(
            f"Tendon {i + 1}: {fitted} mu(0) = A + B = {m['mean']:.4f} ± {m['sd']:.2g}{tr('mu0')}{off}; "
            f"{fitted} A = {a['mean']:.3f} ± {a['sd']:.2g}{tr('A')} and B = {b['mean']:.3f} ± {b['sd']:.2g}{tr('B')} "
            f"are sloppy (posterior correlation {tied.correlation(i)[0, 1]:.4f}): at small wraps "
            "alpha cos(alpha) ≈ alpha, so only their sum is seen."
        )
    return out


def advice_table(js: dict) -> tuple[list[str], list[list]]:
    """Header and rows of the advice table from the study's JSON: expectation and, with truth, its check."""
    adv = js["advice"]
    v = adv["verdict"]
    check = {c["joint"]: c for c in adv["check"] or []}
    header = ["joint", "D-criterion", "expected narrowing (linearised)"]
    if check:
        header += ["measured narrowing", "truth in band", "RMSE against truth [N]"]
    rows = []
    for c in adv["candidates"]:
        mark = " (linearised advice)" if c["joint"] == v["linearised_joint"] else ""
        mark += " (measured best)" if c["joint"] == v["measured_best_joint"] else ""
        row = [f"{c['joint']}{mark}", c["log_det"], pct(c["expected_shrinkage"])]
        if check:
            m = check[c["joint"]]
            row += [pct(m["measured_shrinkage"]), pct(m["truth_coverage"]), m["rmse_n"]]
        rows.append(row)
    if check:
        base = adv["check_baseline"]
        rows.append(["none (terminal labels only)", "-", "-", "-", pct(base["truth_coverage"]), base["rmse_n"]])
    return header, rows


def _interval(p) -> str:
    """A profile's 95 % interval; a structural one is flat, whatever point the optimiser stopped at."""
    if p.verdict.startswith("structurally"):
        return "flat (structural)"
    f = lambda v: "open" if v is None else f"{v:.4g}"  # noqa: E731
    return f"[{f(p.ci[0])}, {f(p.ci[1])}]"


def _truth_of(name: str, law: dict) -> str:
    """The simulator's value of a profiled parameter (``A_t1``, ``mu0_g3_t2``...): its law is tied."""
    kind, tendon = name.split("_")[0], int(name.rsplit("_t", 1)[1]) - 1
    return f"{law[kind][tendon]:.3g}"


def profile_table(result: IdentifiabilityResult, fitted: str = "fitted") -> dict:
    """The profile likelihoods as a table: the informative rows, all rows, and the per-guide verdicts counted.

    Returns
    -------
    dict
        ``header``; ``shown``: every tied profile and the per-guide ones with a finite interval;
        ``all``: every profile; ``per_guide``, ``finite``, ``flat`` and ``open``: how many per-guide
        profiles there are, and how many are identifiable, structurally and practically unidentifiable.
    """
    tied, per = result.studies["tied"], result.studies["per-guide"]
    law = result.truth_law
    header = ["law", "parameter", f"{fitted} estimate", "95 % interval", "verdict"] + (["truth"] if law else [])
    every = [(st, q) for st in (tied, per) for profs in st.profiles for q in profs]
    truth = (lambda name: [_truth_of(name, law)]) if law else (lambda name: [])  # noqa: E731

    def row(st, q) -> list:
        return [st.tying, q.name, q.estimate, _interval(q), q.verdict] + truth(q.name)

    verdicts = [q.verdict for st, q in every if st is per]
    return {
        "header": header,
        "shown": [row(st, q) for st, q in every if st is tied or q.verdict == "identifiable"],
        "all": [row(st, q) for st, q in every],
        "per_guide": len(verdicts),
        "finite": verdicts.count("identifiable"),
        "flat": verdicts.count("structurally unidentifiable"),
        "open": verdicts.count("practically unidentifiable"),
    }
