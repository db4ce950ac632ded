"""One job per room: where the environment is read, and how large a module or a class may grow.

Read from the source with :mod:`ast`, as ``tests/test_layers.py`` reads the imports.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The two modules that read the process environment, each once at start-up: the library's
#: variables and the service's settings.
ENVIRONMENT_READERS = {"solver/environment.py", "service/settings.py"}


def _sources():
    for pkg in ("solver", "service"):
        for p in sorted((ROOT / pkg).rglob("*.py")):
            yield p.relative_to(ROOT).as_posix(), ast.parse(p.read_text(), str(p))


def _is_environ(node: ast.AST) -> bool:
    return (isinstance(node, ast.Attribute) and node.attr == "environ" and isinstance(node.value, ast.Name)
            and node.value.id == "os")


def environment_reads(tree: ast.AST) -> list[int]:
    """Lines that look a variable up in ``os.environ`` (copying it whole for a child process is no read)."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            f = node.func
            if (f.attr in ("get", "__getitem__", "__contains__") and _is_environ(f.value)) or \
                    (f.attr == "getenv" and isinstance(f.value, ast.Name) and f.value.id == "os"):
                out.append(node.lineno)
        elif isinstance(node, ast.Subscript) and _is_environ(node.value) and isinstance(node.ctx, ast.Load):
            out.append(node.lineno)
        elif isinstance(node, ast.Compare) and any(isinstance(op, (ast.In, ast.NotIn)) for op in node.ops) \
                and any(_is_environ(c) for c in node.comparators):
            out.append(node.lineno)
    return out


def test_the_environment_is_read_in_one_place():
    stray = [f"{path}:{line}" for path, tree in _sources() if path not in ENVIRONMENT_READERS
             for line in environment_reads(tree)]
    assert stray == []


def test_the_reader_finder_finds_each_kind_of_read():
    src = ("import os\na = os.environ.get('A')\nb = os.environ['B']\nc = 'C' in os.environ\nd = os.getenv('D')\n"
           "e = dict(os.environ, E='1')\nf = {**os.environ}\n")
    assert environment_reads(ast.parse(src)) == [2, 3, 4, 5]
