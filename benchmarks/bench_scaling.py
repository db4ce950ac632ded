"""How set-up, update, element check and peak memory grow with the tet count, with the fitted exponents.

Each size is the bracket of ``tests/data/make_bracket.py`` meshed by gmsh
(``--sizes``, or ``--large`` for the 2M and 4M meshes too), run as
``bench_update.py``'s ``mixed`` (tetmorph's default) and ``harmonic`` (the
peer) cases, each in its own process. The exponent ``b`` of each column is
the least-squares slope of ``log(value)`` against ``log(tets)``: the value
grows as ``tets**b`` over the sizes measured.

    python benchmarks/bench_scaling.py [--large] [--repeats 1]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_solver import bracket_deck  # noqa: E402

#: gmsh MeshSizeMax of the bracket for about 0.1M, 0.5M and 1M tets; ``LARGE``: about 2M and 4M.
SIZES = (0.95, 0.57, 0.44)
LARGE = (0.35, 0.28)
COLUMNS = (("setup_s", "setup s", ".2f"), ("setup_warm_s", "warm setup s", ".2f"), ("update_ms", "update ms", ".1f"),
           ("check_ms", "check ms", ".1f"), ("peak_rss_gb", "peak RSS GB", ".2f"))


def run(size: float, case: str) -> dict:
    """One ``bench_update.py`` case in its own process."""
    out = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_update.py"), "--case", f"{size:g}:{case}"],
                         capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"{case} at size {size:g} failed: {out.stderr.strip().splitlines()[-1]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def exponent(tets: list[int], values: list[float]) -> float:
    """Least-squares slope of log(values) against log(tets)."""
    return float(np.polyfit(np.log(tets), np.log(values), 1)[0])


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--sizes", default=",".join(f"{s:g}" for s in SIZES))
    p.add_argument("--large", action="store_true", help="add the 2M and 4M meshes (about 25 minutes, 7 GB)")
    p.add_argument("--repeats", type=int, default=1)
    a = p.parse_args()
    sizes = [float(s) for s in a.sizes.split(",")] + (list(LARGE) if a.large else [])
    rows = []
    for size in sizes:
        bracket_deck(size)
        t = [run(size, "mixed") for _ in range(a.repeats)]
        h = [run(size, "harmonic") for _ in range(a.repeats)]
        rows.append((size, t, h))
        print(f"size {size:g}: {t[0]['tets']:,} tets done", file=sys.stderr)
    print("| tets | " + " | ".join(label for _, label, _ in COLUMNS) + " | harmonic update ms | update ratio |")
    print("|---:|" + "---:|" * (len(COLUMNS) + 2))
    med: dict[str, list[float]] = {key: [] for key, _, _ in COLUMNS}
    tets = []
    for _size, t, h in rows:
        tets.append(t[0]["tets"])
        cells = []
        for key, _, fmt in COLUMNS:
            v = [r[key] for r in t]
            med[key].append(float(np.median(v)))
            cells.append(f"{np.median(v):{fmt}}" + (f" [{min(v):{fmt}}-{max(v):{fmt}}]" if len(v) > 1 else ""))
        hu = float(np.median([r["update_ms"] for r in h]))
        print(f"| {tets[-1]:,} | " + " | ".join(cells) + f" | {hu:.1f} | {med['update_ms'][-1] / hu:.2f} |")
    if len(tets) > 1:
        print("| exponent b (value ~ tets^b) | " + " | ".join(f"{exponent(tets, med[key]):.2f}"
                                                         for key, _, _ in COLUMNS) + " | | |")


if __name__ == "__main__":
    main()
