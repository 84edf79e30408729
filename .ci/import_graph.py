#!/usr/bin/env python3
"""Check the import graph of tendon_id, learners and friction_models (stdlib only).

    python .ci/import_graph.py [ROOT]   # exit 0 when clean, 1 with each problem listed

Every ``import`` statement counts, at module level or inside a function. It checks:

* no cycle between modules;
* layering: ``tendon_id -> learners -> friction_models``, never back;
* no private name (``_x``) imported from another module;
* the family seam (docs/guide/architecture.rst): the code written once for every transmission
  family (:data:`GENERIC`) imports only itself and the foundation (:data:`FOUNDATION`), and the
  foundation only itself, so neither can import a family's module; a family is reached through
  ``tendon_id.family`` alone. The built-in families' entry modules must lie outside both;
* ``--dot`` prints the graph in Graphviz format instead.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]  # default: the checkout this script is in
PACKAGES = ("tendon_id", "learners", "friction_models")
LAYER = {"tendon_id": 2, "learners": 1, "friction_models": 0}

#: The code written once for every transmission family (a name covers its submodules).
GENERIC = (
    "tendon_id.family",
    "tendon_id.diagnosis",
    "tendon_id.report.calibration",
    "tendon_id.report.fleet",
    "tendon_id.calibration.posterior",
    "tendon_id.calibration.mcmc",
    "tendon_id.calibration.optimize",
    "tendon_id.zoo.estimator",
    "tendon_id.zoo.arrays_file",
    "tendon_id.zoo.registry",
    "tendon_id.zoo.persistence",
    "tendon_id.zoo.testing",
    "tendon_id.data.frame",
    "tendon_id.data.mapping",
    "tendon_id.data.patterns",
    "tendon_id.data.rosbag",
    "tendon_id.report.diagnosis",
    "tendon_id.report.diagnosis_lead",
)
#: What knows no family and every layer may use.
FOUNDATION = (
    "friction_models",
    "tendon_id.errors",
    "tendon_id.checks",
    "tendon_id.registry",
    "tendon_id.atomic",
    "tendon_id.progress",
    "tendon_id.metrics",
    "tendon_id.extras",
    "tendon_id.data.columns",
    "tendon_id.data.io",
    "tendon_id.data.rules",
    "tendon_id.data.select",
    "tendon_id.data.units",
    "tendon_id.report.html",
    "tendon_id.report.truth",
)
#: Where the built-in families are registered (their entry modules must be family modules).
FAMILY_REGISTRY = "tendon_id/family/registry.py"


def modules(root: Path) -> dict[str, Path]:
    out = {}
    for pkg in PACKAGES:
        for path in sorted((root / pkg).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            out[".".join(parts)] = path
    return out


def edges(mods: dict[str, Path]) -> tuple[dict[str, set[str]], list[str]]:
    graph: dict[str, set[str]] = {m: set() for m in mods}
    private = []
    for name, path in mods.items():
        is_pkg = path.name == "__init__.py"
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:  # relative import
                    anchor = name.split(".") if is_pkg else name.split(".")[:-1]
                    anchor = anchor[: len(anchor) - node.level + 1]
                    base = ".".join(anchor + ([node.module] if node.module else []))
                for alias in node.names:
                    sub = f"{base}.{alias.name}"
                    targets.append(sub if sub in mods else base)
                    if alias.name.startswith("_") and not alias.name.startswith("__") and base in mods and base != name:
                        private.append(f"{path}:{node.lineno}: imports private {alias.name} from {base}")
            for t in targets:
                while t and t not in mods and "." in t:
                    t = t.rsplit(".", 1)[0]
                if t in mods and t != name:
                    graph[name].add(t)
    return graph, private


def within(module: str, names: tuple[str, ...]) -> bool:
    """Whether ``module`` is one of ``names`` or inside one of them."""
    return any(module == n or module.startswith(n + ".") for n in names)


def family_entries(root: Path) -> list[str]:
    """The modules named in the family registry's ``BUILTIN`` table (``"module:attribute"``)."""
    path = root / FAMILY_REGISTRY
    if not path.is_file():
        return []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        target = getattr(node, "target", None) or (node.targets[0] if isinstance(node, ast.Assign) else None)
        if isinstance(target, ast.Name) and target.id == "BUILTIN" and isinstance(node.value, ast.Dict):
            return [v.value.partition(":")[0] for v in node.value.values if isinstance(v, ast.Constant)]
    return []


def seam_problems(graph: dict[str, set[str]], root: Path) -> list[str]:
    """Generic code that reaches past the seam, and family entries that are not family modules."""
    out = []
    for a in sorted(graph):
        if within(a, GENERIC):
            allowed, what = GENERIC + FOUNDATION, "generic"
        elif within(a, FOUNDATION):
            allowed, what = FOUNDATION, "foundation"
        else:
            continue
        for b in sorted(graph[a]):
            if not within(b, allowed):
                out.append(f"seam: {what} {a} imports {b}, which is neither generic nor foundation (a family's?)")
    for entry in family_entries(root):
        if within(entry, GENERIC + FOUNDATION):
            out.append(f"seam: the family module {entry} is listed as generic or foundation")
    return out


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def main(argv: list[str]) -> int:
    args = [a for a in argv if not a.startswith("--")]
    mods = modules(Path(args[0]).resolve() if args else ROOT)
    graph, private = edges(mods)
    if "--dot" in argv:
        print("digraph imports {")
        for a in sorted(graph):
            for b in sorted(graph[a]):
                print(f'  "{a}" -> "{b}";')
        print("}")
        return 0
    problems = [f"cycle: {' <-> '.join(c)}" for c in cycles(graph)]
    for a in sorted(graph):
        for b in sorted(graph[a]):
            if LAYER[b.split(".")[0]] > LAYER[a.split(".")[0]]:
                problems.append(f"layering: {a} imports {b}")
    problems += private
    problems += seam_problems(graph, Path(args[0]).resolve() if args else ROOT)
    n_edges = sum(len(v) for v in graph.values())
    for p in problems:
        print(p)
    print(f"{len(mods)} modules, {n_edges} imports: " + ("ok" if not problems else f"{len(problems)} problem(s)"))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
