"""The import graph of ``solver`` and ``service``: no cycles, and no import up the layers.

The graph is read here from the source with :mod:`ast`, every import
counted, at module level or inside a function (a lazy import still ties
the modules together), except those under ``if TYPE_CHECKING:``. An
import of a package's submodule from inside that package is an edge to
the submodule, not to the package's ``__init__``.

The layers, lowest first; a module may import its own layer and the ones
below, never one above:
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Lowest first. A module belongs to the first entry that is it or one of its packages.
LAYERS: list[tuple[str, ...]] = [
    ("solver.errors", "solver.limits", "solver.environment", "solver.documents", "solver.options"),
    ("solver.ops",),
    ("solver.linalg", "solver.validity"),
    ("solver.mesh",),
    ("solver.io", "solver.constraints"),
    ("solver.deform",),
    ("solver.workflows", "solver.testing"),
    ("solver.cli", "solver.kernels", "solver"),
    ("service.errors", "service.settings", "service.binary", "service.format_table"),
    ("service.models", "service.formats", "service.middleware", "service.security", "service.observability",
     "service.strict_json",
     "service.process", "service.client", "service.http_protocol", "service.docs_assets"),
    ("service.state",),
    ("service.api", "service.demo"),
    ("service.app", "service.cluster"),
    ("service.cli", "service"),
]
__doc__ += "\n".join(f"{k}. {', '.join(names)}" for k, names in enumerate(LAYERS)) + "\n"

#: Web frameworks the numerics must not import.
WEB = ("fastapi", "starlette", "uvicorn", "httpx", "websockets", "multipart")


def _modules() -> dict[str, Path]:
    out = {}
    for pkg in ("solver", "service"):
        for p in (ROOT / pkg).rglob("*.py"):
            parts = list(p.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = p
    return out


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip.update(id(n) for n in ast.walk(node))
    return skip


def _imports(name: str, path: Path, mods: dict[str, Path]) -> tuple[set[str], set[str]]:
    """Internal modules ``name`` imports, and the top-level names of external ones."""
    tree = ast.parse(path.read_text())
    skip = _type_checking_nodes(tree)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    internal: set[str] = set()
    external: set[str] = set()
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
            external.update(t.split(".")[0] for t in targets)
            internal.update(t for t in targets if t in mods)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
                external.add(target.split(".")[0])
            subs = [f"{target}.{a.name}" for a in node.names if f"{target}.{a.name}" in mods]
            internal.update(subs)
            if target in mods and (len(subs) < len(node.names)) and not name.startswith(target + "."):
                internal.add(target)  # names from the module itself (not a parent package of the importer)
    internal.discard(name)
    return internal, external


@pytest.fixture(scope="module")
def graph() -> dict[str, set[str]]:
    mods = _modules()
    return {m: _imports(m, p, mods)[0] for m, p in mods.items()}


def _layer(module: str) -> int:
    best = None
    for k, names in enumerate(LAYERS):
        for n in names:
            if (module == n or module.startswith(n + ".")) and (best is None or len(n) > best[1]):
                best = (k, len(n))
    assert best is not None, f"{module} is in no layer: add it to LAYERS"
    return best[0]


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (iterative Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
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


def test_no_import_cycles(graph):
    assert _cycles(graph) == []


def test_the_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_runs_up_the_layers(graph):
    up = sorted(f"{m} (layer {_layer(m)}) imports {t} (layer {_layer(t)})"
                for m, targets in graph.items() for t in targets if _layer(t) > _layer(m))
    assert up == []


def test_the_solver_imports_no_web_framework():
    mods = _modules()
    web = sorted(f"{m} imports {e}" for m, p in mods.items() if m.startswith("solver")
                 for e in _imports(m, p, mods)[1] if e in WEB)
    assert web == []
