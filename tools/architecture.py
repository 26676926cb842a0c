"""The package's layers, what each may import, and a check of the code against them.

    python tools/architecture.py          # the imports between layers; exit 1 on a breach
    python tools/architecture.py --figure docs/figures/architecture.png

The imports are read from the sources (every ``import`` and ``from ... import``, also those
inside functions), nothing is run. docs/architecture.md explains the layers; the tests
(tests/unit/test_architecture.py) hold the code to them.
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "mbs_clearance"

#: the layers from the bottom up: name -> (the modules or sub-packages in it, one line)
LAYERS = {
    "base": (("_warnings", "_checks", "_io", "units"),
             "warnings, input checks, files, units"),
    "numerics": (("numerics", "core"),
                 "the compiled integrator, its methods and its build; know no mechanism"),
    "laws": (("laws",), "contact, friction and oil-film laws, one module each"),
    "model": (("model",), "Linkage, the SliderCrank parameter set, named cases, design fields"),
    "elements": (("elements",), "joint kinds, one module each"),
    "generate": (("generate",), "description -> compiled model"),
    "solve": (("solve",), "runs, DDM, accuracy, Trajectory, the backend registry"),
    "backends": (("backends",), "Exudyn and the ideal joint"),
    "analysis": (("analysis",), "sensitivities, objectives, sections, Lyapunov, periodic orbits"),
    "studies": (("studies",), "GA, tolerance studies, regime maps, executors"),
    "plotting": (("plotting",), "every figure"),
    "cli": (("cli",), "the command line"),
}

#: what each layer may import besides itself (the layers below it, except where noted);
#: the package's __init__ names its public objects by module path and imports on demand
MAY_IMPORT = {
    "base": set(),
    "numerics": {"base"},
    "laws": {"base", "numerics"},
    "model": {"base", "numerics", "laws"},
    "elements": {"base", "numerics", "laws", "model"},
    "generate": {"base", "numerics", "laws", "model", "elements"},
    "solve": {"base", "numerics", "laws", "model", "elements", "generate"},
    "backends": {"base", "numerics", "laws", "model", "elements", "generate", "solve"},
    # analysis works on runs of the reduced model; a cross-check with Exudyn is a study
    "analysis": {"base", "numerics", "laws", "model", "elements", "generate", "solve"},
    "studies": {"base", "numerics", "laws", "model", "elements", "generate", "solve",
                "backends", "analysis"},
    "plotting": {"base", "numerics", "laws", "model", "elements", "generate", "solve",
                 "backends", "analysis"},
    "cli": {"base", "numerics", "laws", "model", "elements", "generate", "solve", "backends",
            "analysis", "studies", "plotting"},
}


def layer_of(module: str) -> str | None:
    """The layer of a module of the package (None: the package itself or not ours)."""
    parts = module.split(".")
    if parts[0] != PACKAGE or len(parts) < 2:
        return None
    for name, (members, _) in LAYERS.items():
        if parts[1] in members:
            return name
    raise ValueError(f"{module} is in no layer: add it to tools/architecture.py's LAYERS")


def _module_name(path: Path, root: Path = ROOT) -> tuple[str, str]:
    """(module, package) of a source file under `root`."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
        return ".".join(parts), ".".join(parts)
    return ".".join(parts), ".".join(parts[:-1])


def imports(root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the modules (and module attributes) of the package and of `validation` it
    imports, read from the sources of the package."""
    graph: dict[str, set[str]] = {}
    for path in sorted((root / PACKAGE).rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        module, package = _module_name(path, root)
        found = graph.setdefault(module, set())
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[:len(package.split(".")) - node.level + 1]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                names = [target] + [f"{target}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            found.update(n for n in names
                         if n.split(".")[0] in (PACKAGE, "validation") and n != PACKAGE)
    return graph


def modules_of(graph: dict[str, set[str]]) -> set[str]:
    return set(graph)


def resolve(name: str, modules: set[str]) -> str | None:
    """The longest module of `modules` that `name` (a module or a module's attribute) is in."""
    while name:
        if name in modules:
            return name
        if "." not in name:
            return None
        name = name.rsplit(".", 1)[0]
    return None


def module_edges(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    """Module -> modules of the package it imports (attributes resolved to their module)."""
    mods = modules_of(graph)
    edges = {}
    for m, names in graph.items():
        edges[m] = {r for n in names if (r := resolve(n, mods)) and r != m and r != PACKAGE}
    return edges


def breaches(graph: dict[str, set[str]]) -> list[str]:
    """Every import that its layer may not make, and every import of `validation`."""
    out = []
    mods = modules_of(graph)
    for m, names in sorted(graph.items()):
        a = layer_of(m)
        for n in sorted(names):
            if n.split(".")[0] == "validation":
                out.append(f"{m} imports {n}: the library never imports validation")
                continue
            r = resolve(n, mods)
            b = layer_of(r) if r else None
            if a is None or b is None or a == b:
                continue
            if b not in MAY_IMPORT[a]:
                out.append(f"{m} ({a}) imports {n} ({b}): {a} may import "
                           f"{', '.join(sorted(MAY_IMPORT[a])) or 'nothing of the package'}")
    return out


def circles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The import circles among modules (strongly connected components of two or more,
    Tarjan's algorithm)."""
    index, low, stack, on, found = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
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
                found.append(sorted(comp))

    sys.setrecursionlimit(10_000)
    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found


def layer_edges(graph: dict[str, set[str]]) -> dict[tuple[str, str], int]:
    """(layer, layer it imports) -> number of importing modules."""
    counts: dict[tuple[str, str], set[str]] = defaultdict(set)
    mods = modules_of(graph)
    for m, names in graph.items():
        a = layer_of(m)
        for n in names:
            r = resolve(n, mods)
            b = layer_of(r) if r else None
            if a and b and a != b:
                counts[(a, b)].add(m)
    return {k: len(v) for k, v in counts.items()}


def lines_of(layer: str) -> int:
    total = 0
    for member in LAYERS[layer][0]:
        p = ROOT / PACKAGE / member
        files = sorted(p.rglob("*.py")) if p.is_dir() else [p.with_suffix(".py")]
        total += sum(len(f.read_text().splitlines()) for f in files
                     if "__pycache__" not in f.parts)
    return total


def figure(path: Path) -> None:
    """The layers as boxes from the bottom up, an arrow for each pair of layers with an
    import (its width the number of importing modules), drawn from the sources."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import FancyArrowPatch, FancyBboxPatch

    graph = imports()
    counts = layer_edges(graph)
    names = list(LAYERS)
    # two columns where two layers sit on one floor (neither imports the other)
    pos = {"base": (0.5, 0), "numerics": (0.5, 1), "laws": (0.5, 2), "model": (0.5, 3),
           "elements": (0.5, 4), "generate": (0.5, 5), "solve": (0.5, 6),
           "backends": (0.25, 7), "analysis": (0.75, 7), "studies": (0.5, 8),
           "plotting": (0.25, 9), "cli": (0.5, 10)}
    fig, ax = plt.subplots(figsize=(8.5, 11))
    w, h = 0.34, 0.5
    for n in names:
        x, y = pos[n]
        ax.add_patch(FancyBboxPatch((x - w / 2, y - h / 2), w, h,
                                    boxstyle="round,pad=0.02", fc="#dfe8f3", ec="#2b4a6f"))
        ax.text(x, y + 0.08, f"{n}  ({lines_of(n)} lines)", ha="center", va="center",
                fontsize=10, weight="bold")
        ax.text(x, y - 0.12, LAYERS[n][1], ha="center", va="center", fontsize=7, wrap=True)
    for (a, b), k in sorted(counts.items()):
        # only the arrows to the next layers down: the rest are implied and would clutter
        if names.index(a) - names.index(b) > 2:
            continue
        (xa, ya), (xb, yb) = pos[a], pos[b]
        # a straight arrow past a box in between bows out to the side instead
        skip = xa == xb and ya - yb > 1
        start = (xa + w / 2, ya) if skip else (xa, ya - h / 2)
        end = (xb + w / 2, yb) if skip else (xb, yb + h / 2)
        ax.add_patch(FancyArrowPatch(start, end, arrowstyle="-|>", mutation_scale=12,
                                     lw=0.6 + 0.25 * k, color="#555555",
                                     connectionstyle=f"arc3,rad={-0.5 if skip else 0.0}"))
    ax.set_xlim(-0.05, 1.05)
    ax.set_ylim(-0.6, 10.6)
    ax.axis("off")
    ax.set_title("mbs_clearance: layers (an arrow: imports; width: importing modules;\n"
                 "arrows past more than one layer in between not drawn)", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--figure", type=Path, help="write the layer picture (PNG) here")
    args = ap.parse_args(argv)
    graph = imports()
    for (a, b), k in sorted(layer_edges(graph).items()):
        print(f"{a:>9} -> {b:<9} {k:3d} module(s)")
    bad = breaches(graph)
    loops = circles(module_edges(graph))
    for line in bad:
        print("BREACH", line)
    for loop in loops:
        print("CIRCLE", " <-> ".join(loop))
    if args.figure:
        figure(args.figure)
        print(f"wrote {args.figure}")
    return 1 if bad or loops else 0


if __name__ == "__main__":
    sys.exit(main())
