"""The pictures of the guide's daily edits (docs/guide/constraints.md), drawn by ``pictures.py``.

One picture per subsection: the part at rest (grey) and the part after the edit, coloured by
displacement on one scale per picture, each solved by the library with a SPEC and a MOVE of the
kind the subsection shows. The CalculiX bracket of the daily-edits tutorial
(``tests/data/make_ccx_bracket.py 4.0``: 100 x 20 x 10 mm, a bore of radius 5 at x = 60, y = 10)
shows the radius, twist and bend, map, offset and lattice edits; the filleted L bracket of
``tests/gmsh_parts.py`` (flanges 6 thick, an inner fillet of radius 5 about x = y = 11, a bore of
radius 3 along x at y = 35, z = 10) the fillet, distance and angle edits.
"""

from __future__ import annotations

import json
import sys
import tempfile
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["GUIDE_EDITS", "GuideEdit", "guide_edit", "guide_edit_scene", "guide_edit_png", "GUIDE_PNGS"]

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "bracket-dimensions"


def _example(name: str) -> dict[str, Any]:
    return json.loads((EXAMPLE / name).read_text())


#: The twist SPEC of examples/bracket-dimensions with its skin bent up instead of twisted.
BEND_SPEC = {"selections": _example("twist.json")["selections"], "fixed": ["clamp"],
             "twist": [{"name": "arm", "selection": "skin", "mode": "bend", "toward": [0, 0, 1],
                        "axis": {"point": [0, 10, 5], "direction": [1, 0, 0]}}]}
#: The bracket's top face (not its clamped end) mapped onto a cylinder along the bar, a crown; the bottom
#: slides on its plane.
MAP_SPEC = {"selections": {"clamp": {"set": "FIXED"},
                           "top": {"box": {"min": [0.001, -1, 9.999], "max": [101, 21, 10.001]},
                                   "boundary_only": True},
                           "bottom": {"box": {"min": [0.001, -1, -0.001], "max": [101, 21, 0.001]},
                                      "boundary_only": True}},
            "fixed": ["clamp"], "sliding": [{"selection": "bottom", "normal": [0, 0, 1]}],
            "map": [{"name": "crown", "selection": "top",
                     "geometry": {"cylinder": {"point": [0, 10, -20], "axis": [1, 0, 0], "radius": 30}}}]}
#: A morph volume over the bracket's free end, clear of the bore.
LATTICE_SPEC = {"selections": {"clamp": {"set": "FIXED"}}, "fixed": ["clamp"],
                "lattice": [{"name": "tip", "box": {"min": [70, -1, -1], "max": [101, 21, 11]},
                             "counts": [3, 2, 2]}]}
LATTICE_MOVE = {"lattice": {"tip": {"displacements": {f"2,{j},{k}": [0, 0, 8] for j in (0, 1) for k in (0, 1)}}}}
#: The fillet SPEC the guide shows, with the web's top face held too.
FILLET_SPEC = {"selections": {"clamp": {"set": "FIXED"}, "top": {"set": "LOAD"}, "fillet": {"set": "FILLET"},
                              "flange": {"set": "INNER_H"}, "web": {"set": "INNER_V"}},
               "fixed": ["clamp", "top"],
               "fillet": [{"name": "corner", "selection": "fillet", "faces": ["flange", "web"]}]}
DISTANCE_SPEC = {"selections": {"clamp": {"set": "FIXED"}, "bore": {"set": "BORE"}, "top": {"set": "LOAD"}},
                 "fixed": ["clamp"],
                 "distance": [{"name": "pitch", "selection": "bore", "reference": "top"}]}
#: The top face of the web turned about the inner corner's fillet axis: the whole web leans.
ANGLE_SPEC = {"selections": {"end": {"set": "FIXED"}, "top": {"set": "LOAD"}},
              "angle": [{"name": "tilt", "selection": "top", "reference": "end", "pivot": [11, 11, 10]}]}

#: Where a picture looks from: its direction, its up and its zoom (``pictures._view``).
ALONG_THE_BAR = ((0.3, -0.8, 0.9), (0.0, 0.0, 1.0), 1.2)
INTO_THE_END = ((0.9, -0.7, 0.6), (0.0, 0.0, 1.0), 1.2)
INTO_THE_PROFILE = ((0.12, -0.1, 1.0), (0.0, 1.0, 0.0), 1.15)
ONTO_THE_WEB = ((-1.0, -0.35, 0.8), (0.0, 1.0, 0.0), 1.1)
View = tuple[tuple[float, float, float], tuple[float, float, float], float]
#: Each picture by its path under ``docs/``: its part, its view, and its variants (title, SPEC, MOVE).
GUIDE_EDITS: dict[str, tuple[str, View, tuple[tuple[str, dict[str, Any], dict[str, Any]], ...]]] = {
    "img/guide-edit-radius.png": ("bracket", ALONG_THE_BAR, (
        ("bore radius 5 -> 7.5 mm", _example("spec.json"), {"radius": {"bore": {"radius": 7.5}}}),
        ("bore radius 5 -> 3 mm", _example("spec.json"), {"radius": {"bore": {"delta": -2.0}}}))),
    "img/guide-edit-twist-bend.png": ("bracket", ALONG_THE_BAR, (
        ("twist 0.6 deg/mm", _example("twist.json"), {"twist": {"bar": {"angle_deg_per_length": 0.6}}}),
        ("bend 0.2 deg/mm, up", BEND_SPEC, {"twist": {"arm": {"angle_deg_per_length": 0.2}}}))),
    "img/guide-edit-map.png": ("bracket", INTO_THE_END, (
        ("top onto a cylinder R 30", MAP_SPEC, {"map": {"crown": {"amount": 1}}}),)),
    "img/guide-edit-offset.png": ("bracket", ALONG_THE_BAR, (
        ("back wall offset 4 mm", _example("spec.json"), {"offset": {"wall": {"distance": 4.0}}}),)),
    "img/guide-edit-lattice.png": ("bracket", ALONG_THE_BAR, (
        ("end control points up 8 mm", LATTICE_SPEC, LATTICE_MOVE),)),
    "img/guide-edit-fillet.png": ("L", INTO_THE_PROFILE, (
        ("fillet radius 5 -> 10 mm", FILLET_SPEC, {"fillet": {"corner": {"radius": 10.0}}}),
        ("fillet radius 5 -> 2.5 mm", FILLET_SPEC, {"fillet": {"corner": {"radius": 2.5}}}))),
    "img/guide-edit-distance-angle.png": ("L", ONTO_THE_WEB, (
        ("bore to top 15 -> 10 mm", DISTANCE_SPEC, {"distance": {"pitch": {"distance": 10.0}}}),
        ("top face 90 -> 105 deg", ANGLE_SPEC, {"angle": {"tilt": {"angle_deg": 105.0}}}))),
}


@dataclass(frozen=True, eq=False)
class GuideEdit:
    """One picture's part at rest and its variants' positions ``V``, solved with ``specs`` and ``moves``.

    ``V0`` the rest positions, ``T`` the corner tets, ``T10`` the quadratic tets (VTK order; ``None`` for a
    linear mesh), ``F`` the boundary triangles, ``view`` where the picture looks from.
    """

    V0: np.ndarray
    T: np.ndarray
    T10: np.ndarray | None
    F: np.ndarray
    V: list[np.ndarray]
    titles: list[str]
    specs: list[dict[str, Any]]
    moves: list[dict[str, Any]]
    reports: list[dict[str, Any]]
    view: View


_PARTS: dict[str, Any] = {}


def part(name: str) -> Any:
    """The mesh ``bracket`` (the tutorial's CalculiX deck, tet10) or ``L`` (the filleted bracket, tet4), built once."""
    if name not in _PARTS:
        from solver import read_mesh

        with tempfile.TemporaryDirectory() as tmp:
            if name == "bracket":
                sys.path.insert(0, str(ROOT / "tests" / "data"))
                try:
                    from make_ccx_bracket import make_ccx_bracket
                finally:
                    sys.path.remove(str(ROOT / "tests" / "data"))
                path = Path(tmp) / "bracket.inp"
                make_ccx_bracket(4.0, str(path))
            else:
                sys.path.insert(0, str(ROOT))
                try:
                    from tests.gmsh_parts import filleted_bracket
                finally:
                    sys.path.remove(str(ROOT))
                path = Path(tmp) / "l_bracket.msh"
                filleted_bracket(path, size=3.0)
            _PARTS[name] = read_mesh(path)
    return _PARTS[name]


def guide_edit(uri: str) -> GuideEdit:
    """Solve the variants of picture ``uri`` of :data:`GUIDE_EDITS`; none may invert an element."""
    from solver import precompute

    name, _, variants = GUIDE_EDITS[uri]
    mesh = part(name)
    out, reports = [], []
    for _, spec, move in variants:
        result = precompute(mesh, spec).solve(move)
        if result.report["inverted_elements"]:
            raise RuntimeError(f"{uri}: {move} inverts {result.report['inverted_elements']} elements")
        out.append(result.V)
        reports.append(result.report)
    return GuideEdit(mesh.V, mesh.T, mesh.T10, mesh.F, out, [t for t, _, _ in variants], [s for _, s, _ in variants],
                     [m for _, _, m in variants], reports, GUIDE_EDITS[uri][1])


def guide_edit_scene(d: GuideEdit) -> Any:
    """The rest shape and one panel per variant, as ``edit_pictures.edit_scene`` draws them, from the part's view."""
    from edit_pictures import edit_scene

    direction, up, zoom = d.view
    return edit_scene(d, view=direction, zoom=zoom, up=up)


def guide_edit_png(uri: str) -> bytes:
    """Picture ``uri`` of :data:`GUIDE_EDITS` as PNG bytes."""
    import pictures

    return pictures.png(guide_edit_scene(guide_edit(uri)))


#: The function that draws each picture, for ``pictures.PICTURES``.
GUIDE_PNGS = {uri: partial(guide_edit_png, uri) for uri in GUIDE_EDITS}
