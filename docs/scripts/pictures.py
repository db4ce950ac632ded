"""Pictures of real morphs for the site, rendered off-screen with pyvista into ``docs/img/``.

``make docs-img`` (run by ``make docs``) writes them; VTK draws without a display through its EGL
window on Mesa's software renderer (the ``docs-img`` target installs Debian's Mesa EGL driver
when it is missing).

Each picture solves the morph its page shows, with the page's own SPEC and MOVE:

* :func:`bracket_displacement_png` -- the first tutorial's morph of ``tests/data/ccx_bracket.inp``
  (its SPEC and MOVE), the rest shape beside the morphed one coloured by displacement;
* :func:`sector_png` -- the sector tutorial's deck (built by the page's own first block) at rest
  and with the page's cyclic SPEC and MOVEs, each drawn with its two neighbours in the ring and
  the cut faces marked (:func:`sector_morphs` holds the arrays);
* :func:`doe_png` -- the design-study tutorial's plan, one panel per variant with its design
  variables, coloured by displacement on one shared scale (:func:`doe_variants`);
* :func:`target_png` -- the target-surface tutorial's plate with its top face on the scan, the
  scan and the morph made by the page's own first two blocks (:func:`target_morph`);
* :func:`inversion_png` -- the first tutorial's SPEC with its move made ten times larger, the
  inverted elements the REPORT names drawn in red, beside the same move with the ``clamp``
  inversion policy (:func:`inversion_morphs`);
* ``edit_pictures.edits_png`` -- the daily-edits tutorial's bracket at rest and with its bore, wall
  and twist edits (``docs/scripts/edit_pictures.py``);
* ``daily_edit_pictures.GUIDE_PNGS`` -- one picture per daily edit of the constraints guide (radius,
  twist and bend, map, offset, lattice, fillet, distance and angle), each the part at rest beside its
  edits (``docs/scripts/daily_edit_pictures.py``).

Run it alone to write the PNGs: ``python docs/scripts/pictures.py [DOCS_DIR]`` (``DOCS_DIR/img/...``,
``docs/`` by default).
"""

from __future__ import annotations

import ast
import contextlib
import io
import math
import re
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["surface", "plotter", "png", "render", "displacement_scene", "displacement_png", "bracket_morph",
           "bracket_displacement_png", "SectorMorphs", "sector_morphs", "sector_scene", "sector_png", "DoeVariants",
           "doe_variants", "doe_scene", "doe_png", "InversionMorphs", "inversion_morphs", "inversion_scene",
           "inversion_png", "PICTURES", "write"]

ROOT = Path(__file__).resolve().parents[2]
#: The first tutorial's SPEC and MOVE (docs/tutorials/morph-a-deck.md, steps 2 and 3).
BRACKET_SPEC = {"selections": {"clamp": {"set": "FIXED"}, "tip": {"set": "LOAD"}, "bore": {"set": "HOLE"}},
                "fixed": ["clamp", "tip"], "handles": {"bore": "bore"}}
BRACKET_MOVE = {"handles": {"bore": {"translation": [-4.0, 0.0, 0.0]}}}
#: The inversion picture's MOVE (docs/guide/validity.md): the first tutorial's bore turned 110° about its axis.
INVERSION_MOVE = {"handles": {"bore": {"rotation": {"axis": [0, 0, 1], "angle_deg": 110}}}}
SECTOR_PAGE = ROOT / "docs" / "tutorials" / "sector-symmetry.md"
TARGET_PAGE = ROOT / "docs" / "tutorials" / "target-surface.md"
STUDY_DATA = ROOT / "tests" / "solver" / "workflows" / "data"  # the design-study tutorial's files

GREY = (0.75, 0.75, 0.78)


# ------------------------------------------------------------------------------------------- drawing

#: Pixels of one panel; a picture of ``(rows, cols)`` panels is ``cols * w`` by ``rows * h``.
PANEL = (480, 330)


def _pv() -> Any:
    """pyvista, rendering off-screen (VTK's EGL window without a display, its X window with one)."""
    import os

    if not os.environ.get("DISPLAY"):  # straight to EGL, without VTK's warning about a missing X server
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    pv.OFF_SCREEN = True
    pv.global_theme.font.family = "arial"
    return pv


def surface(P: np.ndarray, F: np.ndarray, **point_data: np.ndarray) -> Any:
    """The triangles ``F`` on the positions ``P`` as a ``pyvista.PolyData``, with ``point_data``."""
    pv = _pv()
    poly = pv.PolyData(np.asarray(P, dtype=float), np.column_stack([np.full(len(F), 3), F]).ravel())
    for name, values in point_data.items():
        poly.point_data[name] = values
    return poly


def plotter(rows: int, cols: int, panel: tuple[int, int] = PANEL) -> Any:
    """An off-screen ``pyvista.Plotter`` of ``rows`` x ``cols`` panels on white, without links between them."""
    pv = _pv()
    p = pv.Plotter(off_screen=True, shape=(rows, cols), window_size=(cols * panel[0], rows * panel[1]),
                   border=False)
    p.set_background("white")
    return p


def _title(p: Any, text: str, size: int = 11) -> None:
    p.add_text(text, position="upper_edge", font_size=size, color="black", name="title")


def _bar(p: Any, title: str) -> dict[str, Any]:
    return {"title": title, "color": "black", "vertical": True, "position_x": 0.86, "position_y": 0.15,
            "height": 0.7, "width": 0.06, "fmt": "%.2g", "title_font_size": 14, "label_font_size": 12}


def _view(p: Any, lo: np.ndarray, hi: np.ndarray, direction: tuple[float, float, float],
          up: tuple[float, float, float] = (0.0, 0.0, 1.0), zoom: float = 1.0) -> None:
    """Look at the box ``lo``..``hi`` from ``direction`` (parallel projection), the same in every panel."""
    centre = 0.5 * (lo + hi)
    d = np.asarray(direction, dtype=float)
    d /= np.linalg.norm(d)
    span = float(np.linalg.norm(hi - lo))
    p.camera.position = tuple(centre + 3.0 * span * d)
    p.camera.focal_point = tuple(centre)
    p.camera.up = up
    p.enable_parallel_projection()
    p.reset_camera(bounds=(lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]))
    p.camera.zoom(zoom)


def png(p: Any) -> bytes:
    """Render ``p`` and close it: PNG bytes without a date or a software tag."""
    from PIL import Image

    image = p.screenshot(return_img=True, transparent_background=False)
    p.close()
    buf = io.BytesIO()
    Image.fromarray(np.asarray(image)[:, :, :3]).save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def render(p: Any) -> np.ndarray:
    """Render ``p`` (left open) and return its pixels, (h, w, 3) uint8."""
    return np.asarray(p.screenshot(return_img=True, transparent_background=False))[:, :, :3]


def displacement_scene(V0: np.ndarray, V: np.ndarray, F: np.ndarray, title: str, units: str = "mm") -> Any:
    """The boundary faces ``F`` at rest (grey) and moved (coloured by displacement), side by side.

    Parameters
    ----------
    V0, V : (n, 3) float arrays
        Rest and morphed positions.
    F : (k, 3) int array
        Boundary triangles.
    title : str
        Title of the morphed view.
    units : str
        Units of the colour bar.

    Returns
    -------
    pyvista.Plotter
        Two panels: the mesh ``rest``, then ``moved`` with the point data ``displacement``.
    """
    moved = np.linalg.norm(V - V0, axis=1)
    lo, hi = np.minimum(V0.min(0), V.min(0)), np.maximum(V0.max(0), V.max(0))
    p = plotter(1, 2, (640, 360))
    p.subplot(0, 0)
    p.add_mesh(surface(V0, F), color=GREY, smooth_shading=False, name="rest")
    _title(p, "rest")
    _view(p, lo, hi, (0.35, -0.9, 0.75), zoom=1.3)
    p.subplot(0, 1)
    p.add_mesh(surface(V, F, displacement=moved), scalars="displacement", cmap="viridis",
               clim=(0.0, float(moved.max()) or 1.0), name="moved", scalar_bar_args=_bar(p, f"displacement {units}"))
    _title(p, title)
    _view(p, lo, hi, (0.35, -0.9, 0.75), zoom=1.3)
    return p


def displacement_png(V0: np.ndarray, V: np.ndarray, F: np.ndarray, title: str, units: str = "mm") -> bytes:
    """:func:`displacement_scene` as PNG bytes."""
    return png(displacement_scene(V0, V, F, title, units))


def bracket_morph() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The first tutorial's morph of the CalculiX bracket: rest positions, morphed positions, boundary faces."""
    from solver import precompute, read_mesh

    mesh = read_mesh(ROOT / "tests" / "data" / "ccx_bracket.inp")
    result = precompute(mesh, BRACKET_SPEC).solve(BRACKET_MOVE)
    return mesh.V, result.V, mesh.F


def bracket_displacement_png() -> bytes:
    """The first tutorial's morph: the bore of the CalculiX bracket moved 4 mm toward the clamp."""
    return displacement_png(*bracket_morph(), "bore moved 4 mm toward the clamp")


def move_text(move: dict[str, Any]) -> str:
    """A MOVE in a few words: ``rim: scale 1.03 about (0, 0, 4)``."""
    parts = []
    for name, h in move.get("handles", {}).items():
        words = []
        if "translation" in h:
            words.append("moved ({})".format(", ".join(f"{x:g}" for x in h["translation"])) + " mm")
        if "scale" in h:
            words.append(f"scaled {h['scale']:g}")
        if "rotation" in h:
            words.append(f"turned {h['rotation']['angle_deg']:g}°")
        if "pivot" in h:
            words.append("about ({})".format(", ".join(f"{x:g}" for x in h["pivot"])))
        parts.append(f"{name} " + " ".join(words))
    return "; ".join(parts)


# -------------------------------------------------------------------------------------- the sector

@dataclass(frozen=True, eq=False)
class SectorMorphs:
    """The sector tutorial's deck and morphs, as the sector picture draws them.

    Attributes
    ----------
    V0 : (n, 3) float array
        The deck at rest.
    F : (k, 3) int array
        Its boundary triangles.
    A, B : (a,) int arrays
        The nodes of the cut faces ``CUT_A`` (0°) and ``CUT_B`` (at ``angle_deg``).
    angle_deg : float
        The cyclic entry's angle.
    spec : dict
        The page's cyclic SPEC.
    moves : list of dict
        The page's MOVEs of the cyclic section.
    V : list of (n, 3) float arrays
        The morphed positions, one per MOVE.
    """

    V0: np.ndarray
    F: np.ndarray
    A: np.ndarray
    B: np.ndarray
    angle_deg: float
    spec: dict[str, Any]
    moves: list[dict[str, Any]]
    V: list[np.ndarray]


def sector_page_inputs(text: str) -> tuple[str, dict[str, Any], list[dict[str, Any]]]:
    """The sector page's deck block, its cyclic SPEC and the MOVEs its cyclic section loops over."""
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    deck = next(b for b in blocks if "out/sector.inp" in b and "meshio.write" in b)
    cyclic = next(b for b in blocks if "cyclic_spec = " in b)
    names: dict[str, Any] = {}
    moves: list[dict[str, Any]] = []
    for node in ast.walk(ast.parse(cyclic)):
        if isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Name):
            with contextlib.suppress(ValueError):
                names[node.targets[0].id] = ast.literal_eval(node.value)
        if isinstance(node, ast.For) and isinstance(node.iter, ast.Tuple):
            moves = [names[e.id] if isinstance(e, ast.Name) else ast.literal_eval(e) for e in node.iter.elts]
    return deck, names["cyclic_spec"], moves


def target_morph() -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
    """The target-surface tutorial's morph: rest and morphed positions, boundary faces, the blocks' scope.

    Made by the page's first two blocks (the scan, the SPEC and its solve) in a scratch folder; the
    scope holds ``plate``, ``xy``, ``z``, ``top``, ``result``, ...
    """
    blocks = re.findall(r"```python\n(.*?)```", TARGET_PAGE.read_text(), re.S)[:2]
    scope: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as d, contextlib.chdir(d):
        Path("out").mkdir()
        Path("tests").symlink_to(ROOT / "tests", target_is_directory=True)
        with contextlib.redirect_stdout(io.StringIO()):
            for block in blocks:
                exec(compile(block, str(TARGET_PAGE), "exec"), scope)  # noqa: S102 - the page's own blocks
    plate = scope["plate"]
    return plate.V, scope["result"].V, plate.F, scope


def target_png() -> bytes:
    """The plate's top face morphed onto the scan (:func:`target_morph`), beside the plate at rest."""
    V0, V, F, _ = target_morph()
    return displacement_png(V0, V, F, "top face on the scan (amount 1)")


def sector_morphs() -> SectorMorphs:
    """Build the sector tutorial's deck with its own first block, then solve its cyclic MOVEs.

    Returns
    -------
    SectorMorphs
    """
    from solver import precompute, read_mesh

    deck, spec, moves = sector_page_inputs(SECTOR_PAGE.read_text())
    with tempfile.TemporaryDirectory() as d, contextlib.chdir(d):
        Path("out").mkdir()
        with contextlib.redirect_stdout(io.StringIO()):
            exec(compile(deck, str(SECTOR_PAGE), "exec"), {})  # noqa: S102 - the page's own block
        mesh = read_mesh("out/sector.inp")
    sel = spec["selections"]
    (cyclic,) = spec["cyclic"]
    a, b = (mesh.sets[sel[f]["set"]] for f in cyclic["faces"])
    deformer = precompute(mesh, spec)
    return SectorMorphs(mesh.V, mesh.F, a, b, float(cyclic["angle_deg"]), spec, moves,
                        [deformer.solve(m).V for m in moves])


def _turn(deg: float) -> np.ndarray:
    t = math.radians(deg)
    return np.array([[math.cos(t), -math.sin(t), 0.0], [math.sin(t), math.cos(t), 0.0], [0.0, 0.0, 1.0]])


def sector_scene(s: SectorMorphs) -> Any:
    """The sector at rest and after each MOVE, each with its two neighbours in the ring.

    The tutorial's sector (mesh ``sector``, coloured by displacement on one scale) is drawn with
    its images turned by ± the cyclic angle (``neighbour-1``, ``neighbour+1``: the ring's next
    sectors, light grey). Its cut face A is marked by orange dots (``face A``), the face B of the
    neighbour that meets it by black points (``face B``): they coincide when the sector stays
    periodic.

    Parameters
    ----------
    s : SectorMorphs

    Returns
    -------
    pyvista.Plotter
        One panel per shape: rest, then one per MOVE.
    """
    on_a, on_b = np.isin(s.F, s.A).all(axis=1), np.isin(s.F, s.B).all(axis=1)
    shapes = [(s.V0, "rest")] + [(V, move_text(m)) for V, m in zip(s.V, s.moves, strict=True)]
    moved = [np.linalg.norm(V - s.V0, axis=1) for V, _ in shapes]
    top = max(float(m.max()) for m in moved) or 1.0
    R = {k: _turn(k * s.angle_deg) for k in (-1, 0, 1)}
    ring = np.vstack([V @ R[k].T for k in R for V, _ in shapes])
    lo, hi = ring.min(0), ring.max(0)
    p = plotter(1, len(shapes), (420, 400))
    for i, ((V, title), d) in enumerate(zip(shapes, moved, strict=True)):
        p.subplot(0, i)
        for k, keep in ((-1, ~on_b), (1, ~on_a)):  # the faces inside the ring are left out
            p.add_mesh(surface(V @ R[k].T, s.F[keep]), color=(0.88, 0.88, 0.9), name=f"neighbour{k:+d}")
        bar = {**_bar(p, "mm"), "position_x": 0.9, "width": 0.05} if i == len(shapes) - 1 else None
        p.add_mesh(surface(V, s.F[~on_a & ~on_b], displacement=d), scalars="displacement", cmap="viridis",
                   clim=(0.0, top), name="sector", show_scalar_bar=bar is not None, scalar_bar_args=bar or {})
        p.add_points(V[s.A], color="orange", point_size=7, render_points_as_spheres=True, name="face A")
        p.add_points(V[s.B] @ R[-1].T, color="black", point_size=3, render_points_as_spheres=True, name="face B")
        _title(p, title, 10)
        _view(p, lo, hi, (-0.45, -0.75, 0.9), zoom=1.25)
    p.subplot(0, 0)
    p.add_legend([("face A of the sector", "orange"), ("face B of its neighbour", "black")],
                 bcolor="white", border=False, loc="lower left", size=(0.45, 0.1))
    return p


def sector_png() -> bytes:
    """The sector tutorial's deck at rest and after its cyclic MOVEs (:func:`sector_scene`)."""
    return png(sector_scene(sector_morphs()))


# -------------------------------------------------------------------------------------------- the DOE

@dataclass(frozen=True, eq=False)
class DoeVariants:
    """The design-study tutorial's plan, morphed.

    Attributes
    ----------
    V0 : (n, 3) float array
    F : (k, 3) int array
    columns : tuple of str
        The plan's shape names.
    values : (m, c) float array
        The plan's rows.
    V : list of (n, 3) float arrays
        The variant of each row, in plan order.
    """

    V0: np.ndarray
    F: np.ndarray
    columns: tuple[str, ...]
    values: np.ndarray
    V: list[np.ndarray]


def doe_variants() -> DoeVariants:
    """Run the design-study tutorial's plan on its plate, as its step 2 does (``block=4``)."""
    import json

    from solver import precompute, read_mesh
    from solver.workflows import parse_shapes, read_plan, run_doe

    plate = read_mesh(ROOT / "tests" / "data" / "plate.inp")
    deformer = precompute(plate, json.loads((STUDY_DATA / "plate_spec.json").read_text()))
    shapes = parse_shapes(json.loads((STUDY_DATA / "plate_shapes.json").read_text()), deformer)
    plan = read_plan(STUDY_DATA / "plate_plan.csv")
    V: dict[int, np.ndarray] = {}
    doe = run_doe(deformer, shapes, plan, block=4, output=lambda row, res: V.__setitem__(row, res.V))
    return DoeVariants(plate.V, plate.F, plan.columns, plan.values, [V[v.row] for v in doe.variants])


def doe_scene(d: DoeVariants, per_row: int = 4) -> Any:
    """One panel per variant of the plan, titled with its design variables, one displacement scale.

    Parameters
    ----------
    d : DoeVariants
    per_row : int
        Panels per row of the grid.

    Returns
    -------
    pyvista.Plotter
        Panel ``i`` holds the mesh ``variant`` of row ``i`` of the plan (point data ``displacement``)
        and its ``title``; a column of its own the one colour bar.
    """
    moved = [np.linalg.norm(V - d.V0, axis=1) for V in d.V]
    top = max(float(m.max()) for m in moved) or 1.0
    every = np.vstack([d.V0, *d.V])
    lo, hi = every.min(0), every.max(0)
    rows = math.ceil(len(d.V) / per_row)
    pv = _pv()
    w, h = 330, 230
    p = pv.Plotter(off_screen=True, shape=(rows, per_row + 1), window_size=(per_row * w + 110, rows * h),
                   border=False, col_weights=[w] * per_row + [110], groups=[(np.s_[:], per_row)])
    p.set_background("white")
    for i, (V, m) in enumerate(zip(d.V, moved, strict=True)):
        p.subplot(i // per_row, i % per_row)
        actor = p.add_mesh(surface(V, d.F, displacement=m), scalars="displacement", cmap="viridis",
                           clim=(0.0, top), name="variant", show_scalar_bar=False)
        values = [f"{c} {v:g}" for c, v in zip(d.columns, d.values[i], strict=True)]
        half = (len(values) + 1) // 2
        _title(p, f"row {i + 1}: " + ", ".join(values[:half]) + "\n" + ", ".join(values[half:]), 8)
        _view(p, lo, hi, (0.3, -0.8, 0.9), zoom=1.2)
    p.subplot(0, per_row)
    p.add_scalar_bar(mapper=actor.mapper, **{**_bar(p, "mm"), "position_x": 0.2, "width": 0.35})
    return p


def doe_png() -> bytes:
    """The design-study tutorial's variants as small multiples (:func:`doe_scene`)."""
    return png(doe_scene(doe_variants()))


# -------------------------------------------------------------------------------------- the inversion

@dataclass(frozen=True, eq=False)
class InversionMorphs:
    """One MOVE that inverts elements, solved with the ``warn`` and the ``clamp`` policies.

    Attributes
    ----------
    V0 : (n, 3) float array
    T : (m, 4) int array
        Corner tets.
    F : (k, 3) int array
    move : dict
    V, V_clamped : (n, 3) float arrays
        Positions with the ``warn`` policy (the full MOVE) and with ``clamp``.
    inverted : (i,) int array
        The inverted elements the ``warn`` REPORT names (``inverted_ids``), the picture's red ones.
    sj, sj_clamped : (m,) float arrays
        Per-element scaled Jacobian (``DeformResult.cell_quality``) of either result.
    reports : tuple of dict
        The two REPORTs.
    """

    V0: np.ndarray
    T: np.ndarray
    F: np.ndarray
    move: dict[str, Any]
    V: np.ndarray
    V_clamped: np.ndarray
    inverted: np.ndarray
    sj: np.ndarray
    sj_clamped: np.ndarray
    reports: tuple[dict[str, Any], dict[str, Any]]


def inversion_morphs(move: dict[str, Any] | None = None) -> InversionMorphs:
    """The first tutorial's SPEC on its bracket with ``move`` (default :data:`INVERSION_MOVE`), warn and clamp.

    Raises
    ------
    ValueError
        The REPORT lists fewer inverted ids than it counts (more than the REPORT keeps).
    """
    from solver import precompute, read_mesh

    move = INVERSION_MOVE if move is None else move
    mesh = read_mesh(ROOT / "tests" / "data" / "ccx_bracket.inp")
    deformer = precompute(mesh, BRACKET_SPEC)
    warn = deformer.solve(move, inversion="warn", quality="full")
    clamp = deformer.solve(move, inversion="clamp", quality="full")
    ids = np.asarray(warn.report["inverted_ids"], dtype=np.int64)
    if len(ids) != warn.report["inverted_elements"]:
        raise ValueError(f"the REPORT names {len(ids)} of {warn.report['inverted_elements']} inverted elements")
    return InversionMorphs(mesh.V, mesh.T, mesh.F, move, warn.V, clamp.V, ids,
                           warn.cell_quality["scaled_jacobian"], clamp.cell_quality["scaled_jacobian"],
                           (warn.report, clamp.report))


#: Scaled Jacobian below which an element counts as poor in the inversion picture.
POOR_SJ = 0.1
TET_FACES = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])


RED, ORANGE = (0.9, 0.0, 0.0), (1.0, 0.65, 0.0)


def inversion_scene(m: InversionMorphs) -> Any:
    """The MOVE with ``warn`` (inverted elements red) beside the same MOVE with ``clamp``.

    The surface (mesh ``surface``) is translucent grey; the inverted elements of the ``warn`` result
    (those the REPORT names) are drawn whole in red (mesh ``inverted``, cell data ``element``: the
    element of each tet), poor ones (scaled Jacobian below :data:`POOR_SJ`) in orange (mesh ``poor``).
    The ``clamp`` panel reddens the elements whose scaled Jacobian is not positive.

    Parameters
    ----------
    m : InversionMorphs

    Returns
    -------
    pyvista.Plotter
        Two panels: ``warn``, then ``clamp``.
    """
    pv = _pv()
    warn, clamp = m.reports
    every = np.vstack([m.V0, m.V, m.V_clamped])
    lo, hi = every.min(0), every.max(0)
    p = plotter(1, 2, (640, 380))
    panels = ((m.V, m.sj, m.inverted, f"warn: {move_text(m.move)}\n{warn['inverted_elements']} inverted (red)"),
              (m.V_clamped, m.sj_clamped, np.flatnonzero(m.sj_clamped <= 0),
               f"clamp: {clamp['applied_fraction']:.3g} of it applied\n{clamp['inverted_elements']} inverted"))
    for i, (V, sj, bad, title) in enumerate(panels):
        p.subplot(0, i)
        poor = np.setdiff1d(np.flatnonzero(sj < POOR_SJ), bad)
        p.add_mesh(surface(V, m.F), color=GREY, opacity=0.2, name="surface")
        for name, ids, colour in (("poor", poor, ORANGE), ("inverted", bad, RED)):
            if len(ids):
                cells = pv.UnstructuredGrid({pv.CellType.TETRA: m.T[ids]}, np.asarray(V, dtype=float))
                cells.cell_data["element"] = ids
                p.add_mesh(cells, color=colour, name=name, ambient=0.6, diffuse=0.4, specular=0.0)
        _title(p, f"{title}, {len(poor)} poor (orange)", 10)
        _view(p, lo, hi, (0.1, -0.35, 0.95), zoom=1.25)
    return p


def inversion_png() -> bytes:
    """The inversion map and the clamped MOVE beside it (:func:`inversion_scene`)."""
    return png(inversion_scene(inversion_morphs()))


#: Every picture, by its path under ``docs/``, and the function that solves and draws it.
from daily_edit_pictures import GUIDE_PNGS  # noqa: E402 - the guide's daily edits, in a module of their own
from edit_pictures import edits_png  # noqa: E402 - the daily edits' picture lives in a module of its own

PICTURES = {"img/tutorial-bracket-displacement.png": bracket_displacement_png,  # tutorials/morph-a-deck.md
            "img/tutorial-sector-cyclic.png": sector_png,  # tutorials/sector-symmetry.md
            "img/tutorial-doe-variants.png": doe_png,  # tutorials/design-study.md
            "img/tutorial-target-surface.png": target_png,  # tutorials/target-surface.md
            "img/guide-inversion-clamp.png": inversion_png,  # guide/validity.md
            "img/tutorial-alter-dimensions.png": edits_png,  # tutorials/alter-dimensions.md
            **GUIDE_PNGS}  # guide/constraints.md, one per daily edit


def write(docs: Path) -> list[Path]:
    """Solve and render every picture of :data:`PICTURES` into ``docs`` (its ``img/``); the paths written."""
    written = []
    for uri, make in PICTURES.items():
        path = docs / uri
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(make())
        written.append(path)
    return written


if __name__ == "__main__":
    for written in write(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs"):
        print(written.relative_to(ROOT) if written.is_relative_to(ROOT) else written)
