"""The picture of the daily-edits tutorial (docs/tutorials/alter-dimensions.md), drawn by ``pictures.py``.

The bracket the page builds (``tests/data/make_ccx_bracket.py 4.0``) at rest, with its bore 2 mm
larger, its back wall 2 mm thicker, and twisted 0.1 degree per mm, each solved with the page's
own SPECs (``examples/bracket-dimensions/``) and coloured by displacement on one scale.
"""

from __future__ import annotations

import json
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["EDIT_MOVES", "EditVariants", "edit_variants", "edit_scene", "edits_png"]

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "bracket-dimensions"
#: The picture's variants: title, the SPEC file of examples/bracket-dimensions, the MOVE.
EDIT_MOVES = (("bore radius 5 -> 7 mm", "spec.json", {"radius": {"bore": {"radius": 7.0}}}),
              ("back wall 2 mm thicker", "spec.json", {"offset": {"wall": {"distance": 2.0}}}),
              ("twisted 10 degrees end to end", "twist.json", {"twist": {"bar": {"angle_deg_per_length": 0.1}}}))


@dataclass(frozen=True, eq=False)
class EditVariants:
    """The bracket at rest (``V0``), each edit's morph (``V``, in :data:`EDIT_MOVES` order), its boundary."""

    V0: np.ndarray
    V: list[np.ndarray]
    F: np.ndarray
    titles: list[str]


def edit_variants() -> EditVariants:
    """Build the page's bracket in a temporary folder and solve each of :data:`EDIT_MOVES`."""
    sys.path.insert(0, str(ROOT / "tests" / "data"))
    try:
        from make_ccx_bracket import make_ccx_bracket
    finally:
        sys.path.remove(str(ROOT / "tests" / "data"))
    from solver import precompute, read_mesh

    with tempfile.TemporaryDirectory() as tmp:
        deck = Path(tmp) / "bracket.inp"
        make_ccx_bracket(4.0, str(deck))
        mesh = read_mesh(deck)
    deformers: dict[str, Any] = {}
    out = []
    for _, spec_file, move in EDIT_MOVES:
        if spec_file not in deformers:
            deformers[spec_file] = precompute(mesh, json.loads((EXAMPLE / spec_file).read_text()))
        out.append(deformers[spec_file].solve(move).V)
    return EditVariants(mesh.V, out, mesh.F, [t for t, _, _ in EDIT_MOVES])


def edit_scene(d: EditVariants, view: tuple[float, float, float] = (0.3, -0.8, 0.9), zoom: float = 1.2,
               up: tuple[float, float, float] = (0.0, 0.0, 1.0)) -> Any:
    """The rest shape (grey) and one panel per edit, coloured by displacement on one scale.

    Every panel looks at the box of all the shapes from ``view`` (parallel projection, ``up`` upward),
    magnified ``zoom``.

    Returns
    -------
    pyvista.Plotter
        Panel (0, 0) holds the mesh ``rest``; panel (0, k) the mesh ``variant`` of edit ``k``
        (point data ``displacement``) and its title; the last column the colour bar.
    """
    import pictures

    pv = pictures._pv()
    moved = [np.linalg.norm(V - d.V0, axis=1) for V in d.V]
    top = max(float(m.max()) for m in moved) or 1.0
    every = np.vstack([d.V0, *d.V])
    lo, hi = every.min(0), every.max(0)
    w, h = 330, 250
    cols = len(d.V) + 1
    p = pv.Plotter(off_screen=True, shape=(1, cols + 1), window_size=(cols * w + 110, h), border=False,
                   col_weights=[w] * cols + [110])
    p.set_background("white")
    p.subplot(0, 0)
    p.add_mesh(pictures.surface(d.V0, d.F), color=pictures.GREY, name="rest")
    pictures._title(p, "at rest", 9)
    pictures._view(p, lo, hi, view, up, zoom)
    actor = None
    for k, (V, m, title) in enumerate(zip(d.V, moved, d.titles, strict=True), start=1):
        p.subplot(0, k)
        actor = p.add_mesh(pictures.surface(V, d.F, displacement=m), scalars="displacement", cmap="viridis",
                           clim=(0.0, top), name="variant", show_scalar_bar=False)
        pictures._title(p, title, 9)
        pictures._view(p, lo, hi, view, up, zoom)
    p.subplot(0, cols)
    p.add_scalar_bar(mapper=actor.mapper, **{**pictures._bar(p, "mm"), "position_x": 0.2, "width": 0.35})
    return p


def edits_png() -> bytes:
    """The daily-edits tutorial's picture (:func:`edit_scene`) as PNG bytes."""
    import pictures

    return pictures.png(edit_scene(edit_variants()))
