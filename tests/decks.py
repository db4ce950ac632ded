"""Abaqus decks for tests, made from the real ones in ``tests/data``."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

__all__ = ["renumbered"]


def renumbered(deck: Path, out: Path, label: Callable[[int], int]) -> Path:
    """``deck`` with every node number ``L`` written as ``label(L)``: in ``*NODE``, ``*ELEMENT`` and ``*NSET`` lines.

    CAE pre-processors leave gaps and offsets in node numbers; the decks in ``tests/data`` number
    their nodes 1 to n. Element numbers, ``*ELSET`` lists and everything else stay as they are.
    """
    lines, key = [], ""
    for line in deck.read_text().splitlines():
        s = line.strip()
        if s.startswith("**"):
            pass
        elif s.startswith("*"):
            key = s.split(",")[0].strip("* ").upper()
            if key == "NSET" and "GENERATE" in s.upper():
                raise ValueError(f"{deck}: *NSET, GENERATE is not renumbered")
        elif s and key in ("NODE", "ELEMENT", "NSET"):
            f = [x.strip() for x in line.split(",")]
            first = {"NODE": 0, "ELEMENT": 1, "NSET": 0}[key]
            end = 1 if key == "NODE" else len(f)
            f[first:end] = [str(label(int(x))) if x else x for x in f[first:end]]
            line = ", ".join(f)
        lines.append(line)
    out.write_text("\n".join(lines) + "\n")
    return out
