"""A smoke run of ``benchmarks/bench_editor.py --drag`` on the Demo beam (450 tets): its tables come out,
and the split it reports is consistent (a benchmark, not a test of speed: no time is asserted)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _cells(row: str) -> list[str]:
    return [c.strip() for c in row.strip().strip("|").split("|")]


@pytest.mark.slow
def test_the_drag_benchmark_splits_service_and_page_times_on_a_tiny_mesh():
    out = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_editor.py"), "--mesh", "demo",
                          "--drag", "3", "--repeat", "2"], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert out.returncode == 0, out.stderr[-3000:]
    lines = out.stdout.splitlines()
    head = next(i for i, x in enumerate(lines) if x.startswith("| drag → frame on screen ms"))
    names, row = _cells(lines[head]), _cells(lines[head + 2])
    assert "2 drags of 3 steps" in lines[head - 2], lines[head - 2]
    cell = {n: re.fullmatch(r"([\d,.]+) \[([\d,.]+)-([\d,.]+)\]", v) for n, v in zip(names, row, strict=True)}
    assert all(cell.values()), row  # every figure measured: median [min-max]
    num = {n: [float(g.replace(",", "")) for g in m.groups()] for n, m in cell.items()}
    for med, lo, hi in num.values():
        assert lo <= med <= hi
    # the service's update happens between the MOVE's send and its frame's arrival; applying a frame is part
    # of the page's time from its arrival to the rendered frame
    assert num["service update ms (REPORT)"][0] <= num["page: send → frame arrived ms"][0]
    assert num["of which apply ms"][0] <= num["page: arrived → rendered ms"][0]
    assert 0 < num["page share of send → rendered"][0] < 1
    assert num["frames/s applied"][0] > 0 and num["page fps"][0] > 0
