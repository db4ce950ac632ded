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


#: Most lines a module (``wc -l``) and a class (``class`` to its last line) may have.
MODULE_LINES = 700
CLASS_LINES = 300


def oversized(path: str, source: str) -> list[str]:
    """The module ``path`` and each class in it (nested ones too) that are over their limits, by name."""
    out = []
    n = len(source.splitlines())
    if n > MODULE_LINES:
        out.append(f"{path}: {n} lines (module limit {MODULE_LINES})")
    for node in ast.walk(ast.parse(source, path)):
        if isinstance(node, ast.ClassDef):
            n = node.end_lineno - node.lineno + 1
            if n > CLASS_LINES:
                out.append(f"{path}:{node.lineno} class {node.name}: {n} lines (class limit {CLASS_LINES})")
    return out


def test_no_module_and_no_class_is_over_its_limit():
    found = {path: oversized(path, (ROOT / path).read_text()) for path, _ in _sources()}
    over = [line for lines in found.values() for line in lines]
    assert over == [], "split these along a seam:\n" + "\n".join(over)


def test_the_size_finder_names_what_is_one_line_over_and_nothing_at_the_limit():
    inner = "    class Inner:\n" + "        x = 1\n" * CLASS_LINES  # 301 lines, in Outer's 302
    fits = "class Fits:\n" + "    x = 1\n" * (CLASS_LINES - 1)  # 300 lines
    src = "class Outer:\n" + inner + fits + "y = 1\n" * (MODULE_LINES + 1 - 302 - CLASS_LINES)
    assert oversized("m.py", src) == ["m.py: 701 lines (module limit 700)",
                                      "m.py:1 class Outer: 302 lines (class limit 300)",
                                      "m.py:2 class Inner: 301 lines (class limit 300)"]
    assert oversized("m.py", fits) == []
