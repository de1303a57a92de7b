"""The house as built: no import circles, no import that climbs from a lower layer to a higher
one, no module over 500 lines, Qt only in ``ares.gui``, ``ares.analysis`` pure.

Read from the source alone (ast), every import anywhere in a module (top level or inside a
function) that names a module of ``ares``: what a newcomer tracing the imports would follow.
The layer order is the one README.md's module map draws; change both together.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

ARES = Path(__file__).resolve().parents[1] / "ares"

# Lowest first. A module may import its own package, and any package of a lower layer;
# never one of a higher layer. Packages in one layer do not import each other.
LAYERS = [
    ["errors"],
    ["labels", "safefile", "malloc"],
    ["analysis"],
    ["memory_base"],
    ["hardware"],
    ["sim"],
    ["protocol"],
    ["rig"],
    ["rundir"],
    ["results"],
    ["report"],
    ["scan"],
    ["tuning", "batch"],
    ["commands"],
    ["gui"],
    ["cli", "jit"],
]
# the rooms of ares.analysis, lowest first, with the same rule among them
ROOMS = [["kernels"], ["stats"], ["spatial"], ["noise"], ["ptc"], ["emva"], ["optics", "defects", "lowlight"]]
QT = ("PySide6", "pyqtgraph", "shiboken6")
IO = ("h5py", "PIL", "matplotlib", "serial", "usb", "smbus2", "pypdf", "lxml", "sqlite3", "dask")


def _modules() -> dict[str, Path]:
    mods = {}
    for p in ARES.rglob("*.py"):
        parts = p.relative_to(ARES.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        mods[name] = p
    return mods


MODS = _modules()


def _imports(name: str, path: Path):
    """(imported module name, line) for every import in ``path``, relative ones resolved."""
    tree = ast.parse(path.read_text(), str(path))
    base = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            mod = node.module or ""
            if node.level:
                b = base
                for _ in range(node.level - 1):
                    b = b.rpartition(".")[0]
                mod = f"{b}.{mod}" if mod else b
            for a in node.names:
                yield (f"{mod}.{a.name}" if f"{mod}.{a.name}" in MODS else mod), node.lineno


def _resolve(target: str) -> str | None:
    while target and target not in MODS:
        target = target.rpartition(".")[0]
    return target or None


def _edges() -> dict[str, set[tuple[str, int]]]:
    out = {}
    for m, p in MODS.items():
        es = set()
        for t, line in _imports(m, p):
            if t.split(".")[0] != "ares":
                continue
            r = _resolve(t)
            # importing one's own package (its __init__) is not an edge
            if r and r != m and not (MODS[r].name == "__init__.py" and m.startswith(r + ".")):
                es.add((r, line))
        out[m] = es
    return out


edges = functools.cache(_edges)  # read when a test asks (once): not at collection, in every xdist worker


def _rank(order, key: str) -> int | None:
    for i, names in enumerate(order):
        if key in names:
            return i
    return None


def _layer(mod: str) -> str:
    parts = mod.split(".")
    return parts[1] if len(parts) > 1 else "ares"


def _room(mod: str) -> str | None:
    parts = mod.split(".")
    return parts[2] if len(parts) > 3 and parts[1] == "analysis" else None


def circles(edges) -> list[list[str]]:
    """Strongly connected sets of >= 2 modules (Tarjan, iterative)."""
    index, low, on, stack, out, n = {}, {}, set(), [], [], 0
    graph = {m: [t for t, _ in es] for m, es in edges.items()}
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(graph[root]))]
        index[root] = low[root] = n
        n += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = n
                    n += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(graph.get(w, ()))))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
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
    return out


def test_every_package_is_in_the_layer_order():
    tops = {_layer(m) for m in MODS if m != "ares"}
    placed = {n for names in LAYERS for n in names}
    assert tops <= placed, f"place these in LAYERS (and README's module map): {sorted(tops - placed)}"
    rooms = {_room(m) for m in MODS} - {None}
    assert rooms <= {n for names in ROOMS for n in names}, sorted(rooms)


def test_no_import_circles():
    assert circles(edges()) == []


def test_the_cycle_finder_finds_a_circle():
    assert circles({"a": {("b", 1)}, "b": {("c", 1)}, "c": {("a", 1)}, "d": {("a", 1)}}) == [["a", "b", "c"]]


def test_no_import_climbs_a_layer():
    climbs = []
    for m, es in edges().items():
        for t, line in es:
            a, b = _layer(m), _layer(t)
            if a != b and a != "ares" and b != "ares":
                ra, rb = _rank(LAYERS, a), _rank(LAYERS, b)
                if ra is not None and rb is not None and rb >= ra:
                    climbs.append(f"{MODS[m].relative_to(ARES.parent)}:{line}: {m} imports {t}")
            ra, rb = _room(m), _room(t)
            if ra and rb and ra != rb and _rank(ROOMS, rb) >= _rank(ROOMS, ra):
                climbs.append(f"{MODS[m].relative_to(ARES.parent)}:{line}: {m} imports {t}")
    assert climbs == []


def test_analysis_imports_nothing_of_ares_but_errors():
    bad = [f"{m} imports {t}" for m, es in edges().items() if m.startswith("ares.analysis")
           for t, _ in es if not (t.startswith("ares.analysis") or t == "ares.errors")]
    assert bad == []


def test_no_module_over_500_lines():
    long = {m: n for m, p in MODS.items() if (n := len(p.read_text().splitlines())) > 500}
    assert long == {}


def test_qt_only_in_the_window_and_no_io_in_analysis():
    bad = []
    for m, p in MODS.items():
        for t, line in _imports(m, p):
            top = t.split(".")[0]
            if top in QT and _layer(m) != "gui":
                bad.append(f"{m}:{line} imports {t}")
            if top in IO and m.startswith("ares.analysis"):
                bad.append(f"{m}:{line} imports {t}")
    assert bad == []


def test_each_package_says_what_it_holds():
    missing = [m for m, p in MODS.items() if p.name == "__init__.py" and not ast.get_docstring(ast.parse(p.read_text()))]
    assert missing == []
