"""Run a tutorial page's code blocks as written: its Python and shell blocks, in the order they appear.

``tests/test_docs.py`` runs every tutorial this way; ``tests/cluster/test_cluster_tutorial.py`` runs
the cluster page, which needs PostgreSQL and HAProxy.

A page shows what a block prints in a ```` ```text ```` block after it (with only prose between
them). ``steps_with_output`` pairs each code block with that text, and ``run_steps`` then checks
the block's standard output against it with ``check_output``: the same lines, every word the same,
every number the same to about four significant digits, and ``…`` wherever the page marks a value
that changes from run to run (a time, an id, a port).
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import re
import subprocess
import sys
from pathlib import Path

__all__ = ["steps", "steps_with_output", "run_steps", "check_output", "output_mismatch"]

#: Any fenced block of a page: its language (possibly empty) and its text.
FENCE = re.compile(r"^```([\w-]*)\n(.*?)^```", re.S | re.M)
#: A number as Python, numpy or printf print it: ``-3``, ``0.61``, ``1.4467e-04``, ``.5``.
NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
#: The mark of a value that varies from run to run; on a line of its own, any number of lines.
ANY = "…"
#: Two printed numbers agree when they differ by at most this share of the larger one ...
REL = 1e-3
#: ... or when both are round-off: smaller than this in magnitude.
TINY = 1e-12


def steps(text: str) -> list[tuple[str, str]]:
    """The ``python`` and ``sh`` fenced blocks of a page, as ``(language, code)`` in page order."""
    return [(lang, code) for lang, code, _ in steps_with_output(text)]


def steps_with_output(text: str) -> list[tuple[str, str, str | None]]:
    """The ``python`` and ``sh`` blocks of a page, each with the ``text`` block that shows its output.

    Returns ``(language, code, expected)`` in page order; ``expected`` is the text of the first
    ```` ```text ```` block after the code block when no other fenced block comes between them,
    else ``None`` (the page shows no output for that block).
    """
    fences = FENCE.findall(text)
    out: list[tuple[str, str, str | None]] = []
    for k, (lang, code) in enumerate(fences):
        if lang in ("python", "sh"):
            follows = fences[k + 1] if k + 1 < len(fences) else None
            out.append((lang, code, follows[1] if follows and follows[0] == "text" else None))
    return out


def _numbers_agree(expected: str, got: str) -> bool:
    if not re.search(r"[.eE]", expected + got):  # integers: counts, ids, exit codes
        return int(expected) == int(got)
    e, g = float(expected), float(got)
    return (abs(e) < TINY and abs(g) < TINY) or math.isclose(e, g, rel_tol=REL)


def _line_pattern(line: str) -> tuple[re.Pattern, list[str]]:
    """A regex for a line of expected output, and the numbers it holds (one group each)."""
    parts, numbers, at = [], [], 0
    for m in re.finditer(rf"{NUMBER.pattern}|{ANY}", line):
        parts.append(re.escape(line[at:m.start()]))
        if m.group() == ANY:
            parts.append(".*?")
        else:
            parts.append(f"({NUMBER.pattern})")
            numbers.append(m.group())
        at = m.end()
    parts.append(re.escape(line[at:]))
    return re.compile("".join(parts)), numbers


def _line_mismatch(expected: str, got: str) -> str | None:
    pattern, numbers = _line_pattern(expected)
    m = pattern.fullmatch(got)
    if m is None:
        return "the words differ"
    for e, g in zip(numbers, m.groups(), strict=True):
        if not _numbers_agree(e, g):
            return f"{g} where the page shows {e}"
    return None


def _lines(text: str) -> list[str]:
    lines = [" ".join(line.split()) for line in text.splitlines()]  # runs of blanks count as one
    while lines and not lines[-1]:
        lines.pop()
    while lines and not lines[0]:
        lines.pop(0)
    return lines


def output_mismatch(expected: str, got: str) -> str | None:
    """Why ``got`` is not the output ``expected`` shows, or ``None`` when it is.

    Lines are compared one to one, blanks collapsed. In a line, ``…`` stands for any text and
    every other word must be the same; numbers agree when both are integers and equal, or when
    they differ by at most ``REL`` of the larger (about four significant digits), or when both are
    below ``TINY`` (round-off). A line that is ``…`` alone stands for any number of lines.
    """
    want, have = _lines(expected), _lines(got)
    first: list[str] = []

    def match(i: int, j: int) -> bool:
        if i == len(want):
            return j == len(have)
        if want[i] == ANY:
            return any(match(i + 1, k) for k in range(j, len(have) + 1))
        if j == len(have):
            first.append(f"line {j + 1}: missing, the page shows {want[i]!r}")
            return False
        why = _line_mismatch(want[i], have[j])
        if why is not None:
            first.append(f"line {j + 1}: {why}\n  page: {want[i]!r}\n  run:  {have[j]!r}")
            return False
        return match(i + 1, j + 1)

    if match(0, 0):
        return None
    return first[0] if first else f"{len(have) - len(want)} more lines than the page shows"


def check_output(expected: str, got: str, where: str) -> None:
    """Fail with the first difference when ``got`` is not what the page shows after a block."""
    why = output_mismatch(expected, got)
    assert why is None, f"{where}: the output is not what the page shows: {why}\n--- printed:\n{got}"


class _Tee(io.StringIO):
    """Standard output kept for the check and still shown (pytest captures it as usual)."""

    def __init__(self, through):
        super().__init__()
        self.through = through

    def write(self, s: str) -> int:
        self.through.write(s)
        return super().write(s)


def run_steps(blocks: list[tuple], cwd: Path, name: str, timeout: float = 600) -> dict:
    """Run ``blocks`` in order: Python blocks in one shared scope, each shell block in ``bash -euo pipefail``.

    ``blocks`` are ``(language, code)`` pairs as ``steps`` gives them, or ``(language, code,
    expected)`` as ``steps_with_output`` does: a block with an ``expected`` text must print it
    (``check_output``). Shell blocks run in ``cwd`` with the current environment. Every
    ``contextlib.ExitStack`` the Python blocks left in their scope is closed at the end, also when
    a block fails.

    Returns
    -------
    dict
        The Python blocks' scope.
    """
    scope: dict = {}
    try:
        for n, (lang, code, *rest) in enumerate(blocks, 1):
            expected = rest[0] if rest else None
            where = f"{name}, block {n} ({lang})"
            if lang == "python":
                printed = _Tee(sys.stdout)
                with contextlib.redirect_stdout(printed):
                    exec(compile(code, name, "exec"), scope)  # noqa: S102 - the page's own code
                stdout = printed.getvalue()
            else:
                r = subprocess.run(["bash", "-euo", "pipefail", "-c", code], cwd=cwd, capture_output=True,
                                   text=True, timeout=timeout, env=dict(os.environ))
                assert r.returncode == 0, f"{where}:\n{code}\n{r.stdout[-2000:]}{r.stderr[-2000:]}"
                stdout = r.stdout
            if expected is not None:
                check_output(expected, stdout, where)
    finally:  # a server or a client the page opened is closed even when a block fails
        for value in scope.values():
            if isinstance(value, contextlib.ExitStack):
                value.close()
    return scope
