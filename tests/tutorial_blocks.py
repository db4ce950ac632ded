"""Run a tutorial page's code blocks as written: its Python and shell blocks, in the order they appear.

``tests/test_docs.py`` runs every tutorial this way; ``tests/cluster/test_cluster_tutorial.py`` runs
the cluster page, which needs PostgreSQL and HAProxy.
"""

from __future__ import annotations

import contextlib
import os
import re
import subprocess
from pathlib import Path

__all__ = ["steps", "run_steps"]


def steps(text: str) -> list[tuple[str, str]]:
    """The ``python`` and ``sh`` fenced blocks of a page, as ``(language, code)`` in page order."""
    return re.findall(r"```(python|sh)\n(.*?)```", text, re.S)


def run_steps(blocks: list[tuple[str, str]], cwd: Path, name: str, timeout: float = 600) -> dict:
    """Run ``blocks`` in order: Python blocks in one shared scope, each shell block in ``bash -euo pipefail``.

    Shell blocks run in ``cwd`` with the current environment. Every ``contextlib.ExitStack`` the
    Python blocks left in their scope is closed at the end, also when a block fails.

    Returns
    -------
    dict
        The Python blocks' scope.
    """
    scope: dict = {}
    try:
        for lang, code in blocks:
            if lang == "python":
                exec(compile(code, name, "exec"), scope)  # noqa: S102 - the page's own code
                continue
            r = subprocess.run(["bash", "-euo", "pipefail", "-c", code], cwd=cwd, capture_output=True, text=True,
                               timeout=timeout, env=dict(os.environ))
            assert r.returncode == 0, f"{name}:\n{code}\n{r.stdout[-2000:]}{r.stderr[-2000:]}"
    finally:  # a server or a client the page opened is closed even when a block fails
        for value in scope.values():
            if isinstance(value, contextlib.ExitStack):
                value.close()
    return scope
