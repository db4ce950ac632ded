"""Constraint rows assembled over one system's unknowns, their targets, and REPORT entries."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..ops.unique import unique
from .move import ResolvedMove
from .rows import Block, block_target

__all__ = ["Assembly", "assemble", "block_targets", "describe"]


@dataclass(frozen=True)
class Assembly:
    """Constraint rows of a set of blocks over one system's unknowns.

    Attributes
    ----------
    C : (m, N) csr matrix
    block : (m,) int array
        Block of each row.
    local : (m,) int array
        Row within its block.
    coord : (m,) int array
        Coordinate of an expanded replicated row (vector layout), else -1.
    vector : bool
        Whether unknowns are interleaved coordinates (3 per vertex).
    """

    C: sp.csr_matrix
    block: np.ndarray
    local: np.ndarray
    coord: np.ndarray
    vector: bool


def assemble(blocks: list[Block], umap: np.ndarray, N: int, vector: bool) -> Assembly:
    """Rows of ``blocks`` over unknowns ``umap[vertex]`` (``-1``: not an unknown).

    With ``vector`` the unknowns are ``3 * umap[v] + c``; replicated rows expand
    to three rows (x, y, z). Rows whose vertices are all non-unknowns are left
    out (their vertices are known to the caller).

    Raises
    ------
    ValueError
        A row mixes unknown and non-unknown vertices.
    """
    Cr: list[np.ndarray] = []
    Cc: list[np.ndarray] = []
    Cv: list[np.ndarray] = []
    blk: list[np.ndarray] = []
    loc: list[np.ndarray] = []
    crd: list[np.ndarray] = []

    def put(rows: np.ndarray, cols: np.ndarray, vals: np.ndarray) -> None:
        Cr.append(rows)
        Cc.append(cols)
        Cv.append(vals)

    def tag(block: np.ndarray, local: np.ndarray, coord: np.ndarray) -> None:
        blk.append(block)
        loc.append(local)
        crd.append(coord)

    m = 0
    for b_i, b in enumerate(blocks):
        u = umap[b.vert]
        has = np.zeros(b.nrows, bool)
        has[b.row[u >= 0]] = True
        mixed = np.zeros(b.nrows, bool)
        mixed[b.row[u < 0]] = True
        if np.any(has & mixed):
            raise ValueError(f"{b.kind} {b.name!r}: a row mixes unknown and known vertices")
        keep_rows = np.flatnonzero(has)
        if not keep_rows.size:
            continue
        newrow = np.full(b.nrows, -1, np.int64)
        newrow[keep_rows] = np.arange(keep_rows.size)
        e = has[b.row]
        r, uu, cv = newrow[b.row[e]], u[e], b.coeff[e]
        k = keep_rows.size
        if not vector:
            put(m + r, uu, cv)
            tag(np.full(k, b_i), keep_rows, np.full(k, -1))
            m += k
        elif b.normal is not None or b.entry_normal is not None:
            nrm = b.entry_normal[e] if b.entry_normal is not None else np.asarray(b.normal)[b.row[e]]  # (e, 3)
            put(np.repeat(m + r, 3), (3 * uu[:, None] + np.arange(3)).ravel(), (cv[:, None] * nrm).ravel())
            tag(np.full(k, b_i), keep_rows, np.full(k, -1))
            m += k
        else:
            for c in range(3):
                put(m + 3 * r + c, 3 * uu + c, cv)
            tag(np.full(3 * k, b_i), np.repeat(keep_rows, 3), np.tile(np.arange(3), k))
            m += 3 * k
    def cat(p: list[np.ndarray], dt: type) -> np.ndarray:
        return np.concatenate(p).astype(dt) if p else np.zeros(0, dt)

    C = sp.csr_matrix((cat(Cv, float), (cat(Cr, np.int64), cat(Cc, np.int64))),
                      shape=(m, 3 * N if vector else N))
    return Assembly(C, cat(blk, np.int64), cat(loc, np.int64), cat(crd, np.int64), vector)


def block_targets(blocks: list[Block], asm: Assembly, move: ResolvedMove,
                  rot_at: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Targets ``d`` of the assembled rows: (m, 3) replicated, (m, 1) vector layout."""
    per = {}
    for b_i in unique(asm.block):
        per[int(b_i)] = np.asarray(block_target(blocks[b_i], move, rot_at), np.float64)
    if not asm.vector:
        d = np.zeros((asm.C.shape[0], 3))
        for b_i, t in per.items():
            rows = asm.block == b_i
            d[rows] = t[asm.local[rows]]
        return d
    d = np.zeros((asm.C.shape[0], 1))
    for b_i, t in per.items():
        rows = np.flatnonzero(asm.block == b_i)
        if blocks[b_i].vector:
            d[rows, 0] = t[asm.local[rows]]
        else:
            d[rows, 0] = t[asm.local[rows], asm.coord[rows]]
    return d


def describe(blocks: list[Block], asm: Assembly, rows: np.ndarray, system: str,
             residual: np.ndarray | None = None, limit: int = 100) -> list[dict]:
    """REPORT entries (kind, index, name, vertices[, residual]) for constraint rows ``rows``.

    Rows of one SPEC entry that only differ in coordinate are merged (largest residual).
    """
    out: dict[tuple[int, int], dict] = {}
    for k, r in enumerate(rows):
        b = blocks[int(asm.block[r])]
        key = (int(asm.block[r]), int(asm.local[r]))
        ent = out.get(key)
        if ent is None:
            if len(out) >= limit:
                continue
            ent = {"system": system, "kind": b.kind, "index": b.index, "name": b.name,
                   "vertices": b.row_vertices(int(asm.local[r]))[:20]}
            out[key] = ent
        if residual is not None:
            ent["residual"] = max(ent.get("residual", 0.0), float(residual[k]))
    return list(out.values())
