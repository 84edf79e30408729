"""Local (structural) identifiability: rank, Fisher eigen-spectrum, and the directions named in words.

The Fisher information of a tendon's law is ``F = X^T W X / sigma^2``
(:meth:`tendon_id.calibration.problem.LawProblem.precision`).  Its null space holds the
combinations of parameters the data cannot see at all (structural
non-identifiability); tiny but non-zero eigenvalues are sloppy, practically
unidentifiable directions (Gutenkunst et al. 2007, "Universally sloppy parameter
sensitivities in systems biology models").

The parameters ``A``, ``B`` are dimensionless friction coefficients, the design entries are
wraps in rad, the delta-method weights are in N^2 and ``sigma`` is in N, so ``F`` and its
eigenvalues are dimensionless (per squared friction coefficient): ``1 / sqrt(eigenvalue)`` is
the linearised sd of a unit-norm combination of friction coefficients.

An eigen-direction is *well determined* when the linearised sd of its unit-norm combination,
``1 / sqrt(eigenvalue)``, is at most :data:`WELL_DETERMINED_SD` (the eigenvalue at least
``1 / WELL_DETERMINED_SD^2``); the other identifiable directions are *sloppy*.  The words give
each combination with its largest coefficient 1, and its sd as written.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

#: Singular values of the whitened design below this fraction of the largest are zero
#: (structural): a held pose repeats exactly the same quantised reading, so the gap is wide.
RANK_RTOL = 1e-8

#: Largest linearised sd [-] of a well-determined unit-norm combination of friction coefficients:
#: its 95 % interval (about ±2 sd) is then within ±0.04, a tenth of the friction the paper
#: identifies, ``mu(0) = A + B`` of 0.38-0.40 (Section IV-B; the default recipe's truth).
WELL_DETERMINED_SD = 0.02

#: The Fisher eigenvalue [-] of a direction with that sd: well determined at or above it.
WELL_DETERMINED_EIGENVALUE = 1.0 / WELL_DETERMINED_SD**2


@dataclass
class Spectrum:
    """Identifiability of one tendon's law from its Fisher information.

    Attributes
    ----------
    names : list of str
    eigenvalues : ndarray
        Fisher-information eigenvalues, descending [-] (dimensionless: per squared friction
        coefficient, see the module docstring).
    eigenvectors : ndarray, shape (p, p)
        Columns match ``eigenvalues``.
    rank : int
    null_space : ndarray, shape (p, p - rank)
    sd : ndarray
        Linearised standard deviation per parameter, ``sqrt(diag(F^+))`` (inf when structurally free).
    words : list of str
        The unidentifiable directions, said in the parameters' own words.
    determined : list of str
        Well-determined combinations (eigenvalue at least :data:`WELL_DETERMINED_EIGENVALUE`), said
        in words, best first.
    sloppy : list of str
        Identifiable but sloppy combinations (sd above it), said in words, sloppiest first.
    """

    names: list[str]
    eigenvalues: NDArray[np.float64]
    eigenvectors: NDArray[np.float64]
    rank: int
    null_space: NDArray[np.float64]
    sd: NDArray[np.float64]
    words: list[str] = field(default_factory=list)
    determined: list[str] = field(default_factory=list)
    sloppy: list[str] = field(default_factory=list)

    @property
    def n_params(self) -> int:
        return len(self.names)

    @property
    def condition_number(self) -> float:
        """``lambda_max / lambda_min`` of the Fisher information (inf when rank-deficient)."""
        if self.rank < self.n_params:
            return float("inf")
        return float(self.eigenvalues[0] / self.eigenvalues[-1])

    @property
    def identifiable_condition_number(self) -> float:
        """The same over the identifiable eigenvalues only."""
        ev = self.eigenvalues[: self.rank]
        return float(ev[0] / ev[-1]) if len(ev) else float("nan")

    def combination_sd(self, v: NDArray) -> float:
        """Linearised sd of ``v . theta`` (inf if ``v`` touches the null space)."""
        v = np.asarray(v, dtype=float)
        if self.null_space.size and np.linalg.norm(self.null_space.T @ v) > 1e-6 * np.linalg.norm(v):
            return float("inf")
        ev, V = self.eigenvalues[: self.rank], self.eigenvectors[:, : self.rank]
        return float(np.sqrt(np.sum((V.T @ v) ** 2 / ev)))

    def written_sd(self) -> NDArray[np.float64]:
        """Linearised sd [-] of each identifiable eigen-direction as it is written (largest coefficient 1).

        ``v`` is unit-norm, so ``w = v / max|v|`` has ``sd(w . theta) = 1 / (sqrt(lambda) max|v|)``.
        """
        V = self.eigenvectors[:, : self.rank]
        return 1.0 / (np.sqrt(self.eigenvalues[: self.rank]) * np.max(np.abs(V), axis=0))

    @property
    def n_determined(self) -> int:
        """How many identifiable directions are well determined (:data:`WELL_DETERMINED_SD`)."""
        return int(np.sum(self.eigenvalues[: self.rank] >= WELL_DETERMINED_EIGENVALUE))

    @property
    def n_sloppy(self) -> int:
        """How many identifiable directions are sloppy (above :data:`WELL_DETERMINED_SD`)."""
        return self.rank - self.n_determined


def spectrum(F: NDArray, names: list[str]) -> Spectrum:
    """Eigen-analysis of a Fisher information matrix ``F`` (p, p) with parameter ``names``."""
    F = 0.5 * (F + F.T)
    ev, V = np.linalg.eigh(F)
    order = np.argsort(ev)[::-1]
    ev, V = np.maximum(ev[order], 0.0), V[:, order]
    # Rank on the singular values of the whitened design, sqrt(eigenvalues).
    sv = np.sqrt(ev)
    rank = int(np.sum(sv > RANK_RTOL * sv[0])) if sv[0] > 0 else 0
    null = V[:, rank:]
    sd = np.full(len(names), np.inf)
    for i in range(len(names)):
        e = np.zeros(len(names))
        e[i] = 1.0
        if not null.size or np.linalg.norm(null.T @ e) < 1e-6:
            sd[i] = np.sqrt(np.sum(V[i, :rank] ** 2 / ev[:rank]))
    out = Spectrum(names=list(names), eigenvalues=ev, eigenvectors=V, rank=rank, null_space=null, sd=sd)
    out.words = describe_null_space(out)
    out.determined, out.sloppy = describe_determined(out)
    return out


# ---- words ---------------------------------------------------------------------------------


def _parse(name: str) -> tuple[str, int | None, str]:
    """``"B_g3_t2"`` -> ``("B", 3, "t2")``; ``"A_t1"`` -> ``("A", None, "t1")``."""
    parts = name.split("_")
    kind = parts[0]
    guide = next((int(p[1:]) for p in parts[1:] if p.startswith("g")), None)
    tendon = next((p for p in parts[1:] if p.startswith("t")), "")
    return kind, guide, tendon


def _ranges(guides: list[int]) -> str:
    """``[3, 4, 5, 7]`` -> ``"3–5, 7"``."""
    guides = sorted(set(guides))
    out, start = [], None
    for a, b in zip(guides, guides[1:] + [None]):
        start = a if start is None else start
        if b != a + 1:
            out.append(f"{start}" if start == a else f"{start}–{a}")
            start = None
    return ", ".join(out)


def _tendon_words(names: list[str]) -> str:
    t = {_parse(n)[2] for n in names} - {""}
    return f" for tendon {sorted(t)[0][1:]}" if len(t) == 1 else ""


def describe_combination(v: NDArray, names: list[str], tol: float = 0.08) -> str:
    """A linear combination ``v @ theta`` of the parameters, in words.

    Recognises the shapes that matter here: a single parameter, ``A + B`` of one guide
    (``mu(0)``), the sum of one kind over a run of guides, ``mu(0)`` summed over guides,
    and otherwise writes the leading terms.
    """
    v = np.asarray(v, dtype=float)
    v = v / np.max(np.abs(v))
    if v[np.argmax(np.abs(v))] < 0:
        v = -v
    keep = np.flatnonzero(np.abs(v) > tol)
    parsed = [_parse(names[i]) for i in keep]
    kinds = {p[0] for p in parsed}
    guides = [p[1] for p in parsed]
    tendon = _tendon_words([names[i] for i in keep])
    equal = np.all(np.abs(v[keep] - 1.0) < tol)
    if len(keep) == 1:
        return f"{names[keep[0]]} alone"
    if equal and len(kinds) == 1 and None not in guides:
        return f"only the sum of guides {_ranges(guides)}'s {kinds.pop()}{tendon}"
    if equal and kinds == {"A", "B"}:
        a = sorted(g for (k, g, _) in parsed if k == "A")
        b = sorted(g for (k, g, _) in parsed if k == "B")
        if a == b:
            if a == [None]:
                return f"mu(0) = A + B{tendon}"
            if len(a) == 1:
                return f"mu(0) = A + B of guide {a[0]}{tendon}"
            return f"the sum of mu(0) = A + B over guides {_ranges(a)}{tendon}"
    terms = _written_terms(v, keep, names, tol)
    order = sorted(terms, key=lambda n: -abs(terms[n]))
    text = f"{terms[order[0]]:.2f}·{order[0]}"
    for n in order[1:5]:
        text += f" {'+' if terms[n] > 0 else '−'} {abs(terms[n]):.2f}·{n}"
    return text + (f" … ({len(order) - 5} more terms)" if len(order) > 5 else "")


def _written_terms(v: NDArray, keep: NDArray, names: list[str], tol: float) -> dict[str, float]:
    """The terms of ``v`` (largest coefficient 1) as written: a guide's A and B with equal weights as its mu(0)."""
    # A guide's A and B with (nearly) equal weights act as its mu(0) = A + B: say so.
    terms: dict[str, float] = {}
    index = {names[i]: i for i in keep}
    for i in keep:
        kind, g, t = _parse(names[i])
        partner = names[i].replace("A", "B", 1) if kind == "A" else names[i].replace("B", "A", 1)
        if kind in ("A", "B") and partner in index and abs(v[i] - v[index[partner]]) < tol:
            label = names[i].replace(kind, "mu0", 1)
            terms[label] = 0.5 * (v[i] + v[index[partner]])
        else:
            terms[names[i]] = v[i]
    return terms


def _groups(null: NDArray, tol: float = 1e-6) -> list[list[int]]:
    """Parameters tied together by the null space (connected components of its projector)."""
    P = null @ null.T
    involved = [i for i in range(P.shape[0]) if P[i, i] > tol]
    groups, seen = [], set()
    for i in involved:
        if i in seen:
            continue
        stack, comp = [i], []
        while stack:
            a = stack.pop()
            if a in seen:
                continue
            seen.add(a)
            comp.append(a)
            stack += [b for b in involved if b not in seen and abs(P[a, b]) > tol]
        groups.append(sorted(comp))
    return groups


def describe_null_space(s: Spectrum) -> list[str]:
    """One sentence per group of parameters that the data cannot separate."""
    if s.rank == s.n_params:
        return []
    out = []
    for g in _groups(s.null_space):
        names = [s.names[i] for i in g]
        sub = s.null_space[g]  # (|g|, n0)
        n_free = int(np.linalg.matrix_rank(sub, tol=1e-6))
        n_det = len(g) - n_free
        # Determined combinations inside the group: the complement of the null space there.
        u, sv, _ = np.linalg.svd(sub, full_matrices=True)
        det = u[:, n_free:].T  # (n_det, |g|)
        what = ", ".join(_compress(names))
        if n_det == 0:
            out.append(f"{what}: not determined at all ({n_free} free directions)")
            continue
        combos = [describe_combination(_sparsest(det, k), names) for k in range(min(n_det, 3))]
        tail = "" if n_det <= 3 else f"; and {n_det - 3} more"
        out.append(
            f"{what}: {n_free} free directions; the data sees only {n_det} combination"
            f"{'s' if n_det > 1 else ''}: " + "; ".join(combos) + tail
        )
    return out


def _sparsest(basis: NDArray, k: int) -> NDArray:
    """The ``k``-th basis vector after a row reduction that makes the basis as readable as possible."""
    b = basis.copy()
    # Gauss–Jordan on the columns of largest weight: a reduced basis has few, round terms.
    rows, cols = b.shape
    r = 0
    for c in np.argsort(-np.max(np.abs(b), axis=0)):
        if r == rows:
            break
        piv = r + int(np.argmax(np.abs(b[r:, c])))
        if abs(b[piv, c]) < 1e-9:
            continue
        b[[r, piv]] = b[[piv, r]]
        b[r] /= b[r, c]
        for i in range(rows):
            if i != r:
                b[i] -= b[i, c] * b[r]
        r += 1
    # Prefer the uniform-sum reading when the complement contains the all-ones vector of a kind.
    ones = np.ones(cols) / np.sqrt(cols)
    if k == 0 and np.linalg.norm(basis.T @ (basis @ ones)) > 1 - 1e-6:
        return ones
    return b[k]


def _compress(names: list[str]) -> list[str]:
    """``[A_g1_t2, A_g2_t2, B_g1_t2]`` -> ``["A of guides 1–2 (tendon 2)", "B of guide 1 (tendon 2)"]``."""
    by = {}
    for n in names:
        kind, g, t = _parse(n)
        by.setdefault((kind, t), []).append(g)
    out = []
    for (kind, t), gs in by.items():
        tw = f" (tendon {t[1:]})" if t else ""
        if None in gs:
            out.append(f"{kind}{tw}")
        else:
            out.append(f"{kind} of guide{'s' if len(gs) > 1 else ''} {_ranges(gs)}{tw}")
    return out


def describe_determined(s: Spectrum, max_items: int = 3) -> tuple[list[str], list[str]]:
    """The well-determined combinations (best first) and the sloppy ones (sloppiest first), in words.

    An identifiable eigen-direction is well determined when its eigenvalue is at least
    :data:`WELL_DETERMINED_EIGENVALUE` (unit-norm sd at most :data:`WELL_DETERMINED_SD`), else
    sloppy; at most ``max_items`` of each are said, each with its sd as written (largest coefficient 1).
    """
    sd, ev = s.written_sd(), s.eigenvalues[: s.rank]
    say = lambda k: f"{describe_combination(s.eigenvectors[:, k], s.names)} (sd {sd[k]:.3g})"  # noqa: E731
    # The eigenvalues are descending: the best-determined directions first, the sloppiest last.
    good = [say(k) for k in range(s.rank) if ev[k] >= WELL_DETERMINED_EIGENVALUE][:max_items]
    sloppy = [say(k) for k in reversed(range(s.rank)) if ev[k] < WELL_DETERMINED_EIGENVALUE][:max_items]
    return good, sloppy
