"""Shared fixtures: real meshes from tests/data and ../shared/data, spec helpers."""

from __future__ import annotations

import ast
import functools
import pathlib

import numpy as np
import pytest

from solver import read_mesh

DATA = pathlib.Path(__file__).parent / "data"
#: ../shared/data beside the clone (CI), else the machine-wide copy.
SHARED = next((p for p in (pathlib.Path(__file__).resolve().parents[2] / "shared" / "data",
                           pathlib.Path("/work/shared/data")) if p.is_dir()),
              pathlib.Path(__file__).resolve().parents[2] / "shared" / "data")


def pytest_addoption(parser):
    parser.addoption("--docs-pictures", action="store_true", default=False,
                     help="write the editor tutorial's pictures to docs/img/editor/ (make docs-pictures)")


def _module_marks(path: pathlib.Path) -> set[str]:
    """The marks a test module gives all its tests: ``pytestmark = pytest.mark.NAME`` (or a list of them)."""
    try:
        tree = ast.parse(path.read_text(encoding="utf-8"))
    except (OSError, SyntaxError, ValueError):
        return set()  # collected as usual, and any error reported there
    marks: set[str] = set()
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "pytestmark"
                                                for t in node.targets):
            values = node.value.elts if isinstance(node.value, (ast.List, ast.Tuple)) else [node.value]
            for v in values:
                v = v.func if isinstance(v, ast.Call) else v
                if isinstance(v, ast.Attribute) and isinstance(v.value, ast.Attribute) and v.value.attr == "mark":
                    marks.add(v.attr)
    return marks


def pytest_ignore_collect(collection_path: pathlib.Path, config: pytest.Config) -> bool | None:
    """Skip importing a module whose every test the ``-m`` expression deselects.

    Deselection by mark happens after collection, and collecting a schemathesis module
    builds its cases from the whole OpenAPI schema, which took about 35 s per xdist worker
    in ``make check`` for tests it then deselected.
    """
    expr = config.getoption("markexpr", "")
    if not expr or collection_path.suffix != ".py" or not collection_path.name.startswith("test_"):
        return None
    marks = _module_marks(collection_path)
    if not marks:
        return None
    try:
        from _pytest.mark.expression import Expression  # pytest's own -m parser
    except ImportError:  # a pytest without it: collect, and let -m deselect
        return None
    return True if not Expression.compile(expr).evaluate(lambda name, **kw: name in marks) else None


def shared_file(rel: str) -> pathlib.Path:
    """A file of ../shared/data (CI places shared/ beside the clone); fail loudly if absent."""
    p = SHARED / rel
    if not p.exists():
        pytest.fail(f"test data {p} is missing: ../shared/data must sit beside the repository")
    return p


@functools.cache
def load(name: str):
    path = DATA / name if (DATA / name).exists() else shared_file(name)
    return read_mesh(path)


def slab(mesh, lo_frac: float, hi_frac: float, axis: int | None = None, boundary_only: bool = False):
    """A box selection of the slab lo_frac..hi_frac along the longest (or given) axis."""
    V = mesh.V[mesh.referenced]
    lo, hi = V.min(0), V.max(0)
    ax = int(np.argmax(hi - lo)) if axis is None else axis
    L = hi[ax] - lo[ax]
    mn, mx = lo.copy() - 1e-9 * L, hi.copy() + 1e-9 * L
    mn[ax] = lo[ax] + lo_frac * L - 1e-9 * L
    mx[ax] = lo[ax] + hi_frac * L + 1e-9 * L
    sel = {"box": {"min": mn.tolist(), "max": mx.tolist()}}
    if boundary_only:
        sel["boundary_only"] = True
    return sel


def bend_spec(mesh, boundary_only: bool = False, **extra):
    return {"selections": {"fix": slab(mesh, 0.0, 0.1, boundary_only=boundary_only),
                           "hand": slab(mesh, 0.9, 1.0, boundary_only=boundary_only)},
            "fixed": ["fix"], "handles": {"h": "hand"}, **extra}


def bend_move(mesh, angle: float, frac: float) -> dict:
    """MOVE for bend_spec's handle "h": turn ``angle`` degrees about the axis after the longest
    and translate ``frac`` of the diagonal along the one after that."""
    ax, diag = longest_axis(mesh)
    axis = [0.0, 0.0, 0.0]
    axis[(ax + 1) % 3] = 1.0
    return {"handles": {"h": {"translation": (frac * diag * np.eye(3)[(ax + 2) % 3]).tolist(),
                              "rotation": {"axis": axis, "angle_deg": angle}}}}


def distance_to_triangles(p: np.ndarray, A: np.ndarray, B: np.ndarray, C: np.ndarray) -> float:
    """Distance from ``p`` to the nearest of the triangles (A, B, C) (k, 3): exact, by projecting on each
    plane and, where the projection falls outside the triangle, taking the nearest point of its edges."""
    dot = lambda X, Y: np.einsum("ij,ij->i", X, Y)  # noqa: E731 - row-wise dot products
    n = np.cross(B - A, C - A)
    nn = dot(n, n)
    q = p - (dot(p - A, n) / nn)[:, None] * n
    w1 = dot(np.cross(C - B, q - B), n) / nn
    w2 = dot(np.cross(A - C, q - C), n) / nn
    inside = (w1 >= 0) & (w2 >= 0) & (1 - w1 - w2 >= 0)
    best = np.where(inside, np.linalg.norm(p - q, axis=1), np.inf)
    for U, W in ((A, B), (B, C), (C, A)):
        e = W - U
        t = np.clip(dot(p - U, e) / dot(e, e), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(p - (U + t[:, None] * e), axis=1))
    return float(best.min())


def longest_axis(mesh):
    V = mesh.V[mesh.referenced]
    ext = V.max(0) - V.min(0)
    return int(np.argmax(ext)), float(np.linalg.norm(ext))


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
