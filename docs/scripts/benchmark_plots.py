"""Plots of the benchmark tables, drawn from the tables of docs/benchmarks.md when the site is built.

The figure reads the page's own Markdown tables, so it shows what the tables say:

* the update time of tetmorph and of the harmonic peer against mesh size (the "Scaling" table);
* the ratio of tetmorph's update time to the peer's against mesh size (the per-update runs
  and the scaling run), and of a DOE variant's time to a single update.

Run it alone to write the SVG: ``python docs/scripts/benchmark_plots.py docs/benchmarks.md out.svg``.
"""

from __future__ import annotations

import io
import re
import sys
from pathlib import Path

__all__ = ["tables", "series", "update_ratio_svg"]

_NUMBER = re.compile(r"-?\d[\d,]*\.?\d*(?:e-?\d+)?")


def tables(markdown: str) -> list[tuple[str, list[str], list[list[str]]]]:
    """Every table of a page: the heading above it, its header cells and its rows of cells."""
    out: list[tuple[str, list[str], list[list[str]]]] = []
    heading, lines = "", markdown.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("#"):
            heading = line.lstrip("#").strip()
        if line.startswith("|") and i + 1 < len(lines) and re.match(r"^\|[\s:|-]+\|$", lines[i + 1].strip()):
            header = [c.strip() for c in line.strip().strip("|").split("|")]
            rows, i = [], i + 2
            while i < len(lines) and lines[i].startswith("|"):
                rows.append([c.strip().replace("**", "") for c in lines[i].strip().strip("|").split("|")])
                i += 1
            out.append((heading, header, rows))
            continue
        i += 1
    return out


def _number(cell: str) -> float | None:
    m = _NUMBER.search(cell)
    return float(m.group().replace(",", "")) if m else None


def _tets(cell: str) -> float | None:
    m = re.match(r"([\d.,]+)\s*([kM]?)", cell)
    if not m:
        return None
    scale = {"k": 1e3, "M": 1e6, "": 1.0}[m.group(2)]
    return float(m.group(1).replace(",", "")) * scale


def series(markdown: str) -> dict[str, list[tuple[float, float]]]:
    """The (tets, value) points of each plotted series."""
    found: dict[str, list[tuple[float, float]]] = {"tetmorph update ms": [], "harmonic update ms": [],
                                                   "per update": [], "scaling run": [], "DOE variant": []}
    for heading, header, rows in tables(markdown):
        if heading.startswith("Scaling") and "update ratio" in header:
            t, u, h, r = (header.index(c) for c in ("tets", "update ms", "harmonic update ms", "update ratio"))
            for row in rows:
                n = _tets(row[t])
                if n is None:
                    continue
                found["tetmorph update ms"].append((n, _number(row[u])))
                found["harmonic update ms"].append((n, _number(row[h])))
                found["scaling run"].append((n, _number(row[r])))
        elif heading.startswith("Per update") and "bracket" in header and "update ms" in header:
            b, u = header.index("bracket"), header.index("update ms")
            for row in rows:
                if "tetmorph" in row[header.index("case")] and _tets(row[b]) is not None:
                    found["per update"].append((_tets(row[b]), _number(row[u + 1])))
        elif heading.startswith("DOE") and "wall / single update" in header:
            w = header.index("wall / single update")
            for row in rows:
                if "one-shot process, block 16 (the default)" in row[header.index("case")]:
                    found["DOE variant"].append((_tets(row[header.index("tets")]), _number(row[w])))
    return {k: [(x, y) for x, y in v if x is not None and y is not None] for k, v in found.items()}


def update_ratio_svg(markdown: str) -> bytes:
    """The figure as SVG bytes (deterministic: no date, fixed ids)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams["svg.hashsalt"] = "tetmorph"
    data = series(markdown)
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    for name, style in (("tetmorph update ms", "o-"), ("harmonic update ms", "s--")):
        if data[name]:
            x, y = zip(*sorted(data[name]), strict=True)
            left.loglog(x, y, style, label=name.replace(" update ms", ""))
    left.set(xlabel="tetrahedra", ylabel="update ms (median)", title="One update against mesh size")
    left.legend()
    left.grid(True, which="both", alpha=0.3)
    for name, style in (("per update", "o"), ("scaling run", "s-"), ("DOE variant", "^")):
        if data[name]:
            x, y = zip(*sorted(data[name]), strict=True)
            label = {"per update": "update, bench_update.py runs", "scaling run": "update, bench_scaling.py",
                     "DOE variant": "a DOE variant / tetmorph's single update"}[name]
            right.semilogx(x, y, style, label=label)
    right.axhline(1.0, color="grey", lw=0.8)
    right.set(xlabel="tetrahedra", ylabel="time ratio", ylim=(0, 2),
              title="tetmorph / harmonic peer against mesh size (below 1: faster)")
    right.legend(fontsize=8)
    right.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="svg", metadata={"Date": None})
    plt.close(fig)
    return buf.getvalue()


if __name__ == "__main__":
    Path(sys.argv[2]).write_bytes(update_ratio_svg(Path(sys.argv[1]).read_text()))
