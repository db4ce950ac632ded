"""A batch process keeps freed memory for reuse instead of returning it to the system."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]

_PROBE = """
import os
import numpy as np
from solver.workflows.batch_memory import keep_freed_memory
def rss_mb():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
applied = keep_freed_memory()
base = rss_mb()
a = np.ones(8 << 20)  # 64 MB, above glibc's largest default mmap threshold (32 MB)
held = rss_mb() - base
del a
core = getattr(np, "_core", None) or np.core
print(applied, round(held), round(rss_mb() - base), core.multiarray._get_madvise_hugepage())
"""


def _probe(env_value: str | None) -> tuple[bool, float, float, bool]:
    env = {k: v for k, v in os.environ.items() if k not in ("TETMORPH_BATCH_MALLOC", "NUMPY_MADVISE_HUGEPAGE")}
    if env_value is not None:
        env["TETMORPH_BATCH_MALLOC"] = env_value
    out = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, check=True, env=env,
                         timeout=60, cwd=ROOT)
    applied, held, after, huge = out.stdout.split()
    return applied == "True", float(held), float(after), huge == "True"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_a_batch_process_keeps_freed_memory_and_the_default_returns_it():
    applied, held, kept, huge = _probe(None)
    off, held_off, returned, huge_off = _probe("0")
    assert applied and not off
    assert not huge and huge_off  # NumPy's huge-page advice: off in a batch process, as it was otherwise
    assert held > 60 and held_off > 60  # the array was resident in both
    assert kept > 60  # freed, kept for the next block's temporaries
    assert returned < 8  # the default gives a freed 64 MB block back at once
