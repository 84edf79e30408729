#!/usr/bin/env python3
"""Check the import graph of tendon_id, learners and friction_models (stdlib only).

    python .ci/import_graph.py [ROOT]   # exit 0 when clean, 1 with each problem listed

Every ``import`` statement counts, at module level or inside a function. It checks:

* no cycle between modules;
* layering: ``tendon_id -> learners -> friction_models``, never back;
* no private name (``_x``) imported from another module;
* ``--dot`` prints the graph in Graphviz format instead.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]  # default: the checkout this script is in
PACKAGES = ("tendon_id", "learners", "friction_models")
LAYER = {"tendon_id": 2, "learners": 1, "friction_models": 0}


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
    n_edges = sum(len(v) for v in graph.values())
    for p in problems:
        print(p)
    print(f"{len(mods)} modules, {n_edges} imports: " + ("ok" if not problems else f"{len(problems)} problem(s)"))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
