"""Pictures of real morphs for the site, rendered when it is built (matplotlib, off-screen).

Each picture solves the morph its page shows, with the page's own SPEC and MOVE:

* :func:`bracket_displacement_png` -- the first tutorial's morph of ``tests/data/ccx_bracket.inp``
  (its SPEC and MOVE), the rest shape beside the morphed one coloured by displacement;
* :func:`sector_png` -- the sector tutorial's deck (built by the page's own first block) at rest
  and with the page's cyclic SPEC and MOVEs, each drawn with its two neighbours in the ring and
  the cut faces marked (:func:`sector_morphs` holds the arrays);
* :func:`doe_png` -- the design-study tutorial's plan, one panel per variant with its design
  variables, coloured by displacement on one shared scale (:func:`doe_variants`);
* :func:`inversion_png` -- the first tutorial's SPEC with its move made ten times larger, the
  inverted elements the REPORT names drawn in red, beside the same move with the ``clamp``
  inversion policy (:func:`inversion_morphs`).

Run it alone to write the PNGs: ``python docs/scripts/pictures.py OUT_DIR`` (``OUT_DIR/img/...``).
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

__all__ = ["displacement_png", "bracket_displacement_png", "SectorMorphs", "sector_morphs", "sector_figure",
           "sector_png", "DoeVariants", "doe_variants", "doe_figure", "doe_png", "InversionMorphs",
           "inversion_morphs", "inversion_figure", "inversion_png", "PICTURES"]

ROOT = Path(__file__).resolve().parents[2]
#: The first tutorial's SPEC and MOVE (docs/tutorials/morph-a-deck.md, steps 2 and 3).
BRACKET_SPEC = {"selections": {"clamp": {"set": "FIXED"}, "tip": {"set": "LOAD"}, "bore": {"set": "HOLE"}},
                "fixed": ["clamp", "tip"], "handles": {"bore": "bore"}}
BRACKET_MOVE = {"handles": {"bore": {"translation": [-4.0, 0.0, 0.0]}}}
#: The inversion picture's MOVE (docs/guide/validity.md): the first tutorial's bore turned 110° about its axis.
INVERSION_MOVE = {"handles": {"bore": {"rotation": {"axis": [0, 0, 1], "angle_deg": 110}}}}
SECTOR_PAGE = ROOT / "docs" / "tutorials" / "sector-symmetry.md"
STUDY_DATA = ROOT / "tests" / "solver" / "workflows" / "data"  # the design-study tutorial's files
SUN = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
GREY = (0.75, 0.75, 0.78)


# ------------------------------------------------------------------------------------------- drawing

def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _shade(P: np.ndarray, F: np.ndarray, rgb: np.ndarray) -> np.ndarray:
    """Face colours ``rgb`` (k, 3) lit by a fixed sun, from the faces' normals."""
    n = np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-300
    return np.clip(rgb * (0.55 + 0.45 * np.clip(n @ SUN, 0.0, 1.0))[:, None], 0.0, 1.0)


def _frame(ax: Any, lo: np.ndarray, hi: np.ndarray, title: str, elev: float, azim: float, zoom: float = 1.2,
           size: float | None = 10, y: float = 0.92) -> None:
    """Limits, equal aspect, no axes, a title inside the panel (``size`` None: the default font size)."""
    ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), zlim=(lo[2], hi[2]))
    ax.set_title(title, y=y, **({} if size is None else {"fontsize": size}))
    ax.set_box_aspect(hi - lo, zoom=zoom)
    ax.set_axis_off()
    ax.view_init(elev=elev, azim=azim)


def _surface(ax: Any, polys: np.ndarray, colours: np.ndarray) -> None:
    """Add filled triangles ``polys`` (k, 3, 3) to ``ax``, edged in their own colour (no seams between them)."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    ax.add_collection3d(Poly3DCollection(polys, facecolors=colours, edgecolors=colours, linewidths=0.3))


def _png(fig: Any, tight: bool = True, dpi: int = 100) -> bytes:
    """The figure as PNG bytes, without a creation date or software tag; the figure is closed.

    ``tight`` crops the empty margins the 3D panels leave.
    """
    plt = _pyplot()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, metadata={"Software": None},
                **({"bbox_inches": "tight", "pad_inches": 0.05} if tight else {}))
    plt.close(fig)
    return buf.getvalue()


def displacement_png(V0: np.ndarray, V: np.ndarray, F: np.ndarray, title: str, units: str = "mm") -> bytes:
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
    bytes
        A PNG without a creation date or software tag.
    """
    plt = _pyplot()
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    moved = np.linalg.norm(V - V0, axis=1)
    norm, cmap = plt.Normalize(0.0, float(moved.max()) or 1.0), plt.get_cmap("viridis")
    lo, hi = V0.min(0), V0.max(0)
    fig = plt.figure(figsize=(12, 3.6))
    for k, (P, name, colour) in enumerate(((V0, "rest", None), (V, title, moved[F].mean(axis=1)))):
        ax = fig.add_subplot(1, 2, k + 1, projection="3d")
        base = np.tile(GREY, (len(F), 1)) if colour is None else cmap(norm(colour))[:, :3]
        ax.add_collection3d(Poly3DCollection(P[F], facecolors=_shade(P, F, base), edgecolors="none"))
        _frame(ax, lo, hi, name, 38, -75, size=None, y=0.9)
    fig.subplots_adjust(left=0, right=0.93, wspace=0)
    fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=fig.axes[1], shrink=0.6,
                 label=f"displacement {units}")
    return _png(fig, tight=False)


def bracket_displacement_png() -> bytes:
    """The first tutorial's morph: the bore of the CalculiX bracket moved 4 mm toward the clamp."""
    from solver import precompute, read_mesh

    mesh = read_mesh(ROOT / "tests" / "data" / "ccx_bracket.inp")
    result = precompute(mesh, BRACKET_SPEC).solve(BRACKET_MOVE)
    return displacement_png(mesh.V, result.V, mesh.F, "bore moved 4 mm toward the clamp")


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


def sector_figure(s: SectorMorphs) -> Any:
    """The sector at rest and after each MOVE, each with its two neighbours in the ring.

    The tutorial's sector is drawn with its images turned by ± the cyclic angle (the ring's next
    sectors, lighter), coloured by displacement on one scale. Its cut face A is marked by orange
    dots, the face B of the neighbour that meets it by black crosses: they coincide when the
    sector stays periodic.

    Parameters
    ----------
    s : SectorMorphs

    Returns
    -------
    matplotlib.figure.Figure
        One panel per shape: rest, then one per MOVE.
    """
    plt = _pyplot()
    on_a, on_b = np.isin(s.F, s.A).all(axis=1), np.isin(s.F, s.B).all(axis=1)
    shapes = [(s.V0, "rest")] + [(V, move_text(m)) for V, m in zip(s.V, s.moves, strict=True)]
    moved = [np.linalg.norm(V - s.V0, axis=1) for V, _ in shapes]
    norm, cmap = plt.Normalize(0.0, max(float(m.max()) for m in moved) or 1.0), plt.get_cmap("viridis")
    R = {k: _turn(k * s.angle_deg) for k in (-1, 0, 1)}
    ring = np.vstack([s.V0 @ R[k].T for k in R])
    lo, hi = ring.min(0) - 1.0, ring.max(0) + 1.0
    hi[2] += 2.0
    fig = plt.figure(figsize=(3.8 * len(shapes), 3.6))
    for i, ((V, title), d) in enumerate(zip(shapes, moved, strict=True)):
        ax = fig.add_subplot(1, len(shapes), i + 1, projection="3d")
        polys, colours = [], []
        for k, keep in ((-1, ~on_b), (0, ~on_a & ~on_b), (1, ~on_a)):  # the faces inside the ring are left out
            F = s.F[keep]
            P = V @ R[k].T
            rgb = (np.tile(GREY, (len(F), 1)) if i == 0 else cmap(norm(d[F].mean(axis=1)))[:, :3])
            if k:
                rgb = 0.6 * rgb + 0.4
            polys.append(P[F])
            colours.append(_shade(P, F, rgb))
        ax.computed_zorder = False  # the marks after the faces, in front of them
        _surface(ax, np.concatenate(polys), np.vstack(colours))
        ax.scatter(*V[s.A].T, s=6, c="tab:orange", depthshade=False, label="face A of the sector")
        ax.scatter(*(V[s.B] @ R[-1].T).T, s=8, c="black", marker="x", linewidths=0.6, depthshade=False,
                   label="face B of its neighbour")
        _frame(ax, lo, hi, title, 35, -120, zoom=1.35)
    fig.axes[0].legend(loc="lower left", fontsize=8, frameon=False)
    fig.subplots_adjust(left=0, right=0.93, wspace=0, top=1, bottom=0)
    fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=fig.axes, shrink=0.6, pad=0.01,
                 label="displacement mm")
    return fig


def sector_png() -> bytes:
    """The sector tutorial's deck at rest and after its cyclic MOVEs (:func:`sector_figure`)."""
    return _png(sector_figure(sector_morphs()))


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


def doe_figure(d: DoeVariants, per_row: int = 4) -> Any:
    """One panel per variant of the plan, titled with its design variables, one displacement scale.

    Parameters
    ----------
    d : DoeVariants
    per_row : int
        Panels per row of the grid.

    Returns
    -------
    matplotlib.figure.Figure
    """
    plt = _pyplot()
    moved = [np.linalg.norm(V - d.V0, axis=1) for V in d.V]
    norm, cmap = plt.Normalize(0.0, max(float(m.max()) for m in moved) or 1.0), plt.get_cmap("viridis")
    every = np.vstack([d.V0, *d.V])
    lo, hi = every.min(0), every.max(0)
    rows = math.ceil(len(d.V) / per_row)
    fig = plt.figure(figsize=(3.0 * per_row + 0.8, 2.1 * rows))
    for i, (V, m) in enumerate(zip(d.V, moved, strict=True)):
        ax = fig.add_subplot(rows, per_row, i + 1, projection="3d")
        rgb = cmap(norm(m[d.F].mean(axis=1)))[:, :3]
        _surface(ax, V[d.F], _shade(V, d.F, rgb))
        values = [f"{c} {v:g}" for c, v in zip(d.columns, d.values[i], strict=True)]
        half = (len(values) + 1) // 2
        title = f"row {i + 1}: " + ", ".join(values[:half]) + "\n" + ", ".join(values[half:])
        _frame(ax, lo, hi, title, 35, -70, zoom=1.4, size=8)
    fig.subplots_adjust(left=0, right=0.92, wspace=0, hspace=0, top=1, bottom=0)
    fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=fig.axes, shrink=0.6, pad=0.01,
                 label="displacement mm")
    return fig


def doe_png() -> bytes:
    """The design-study tutorial's variants as small multiples (:func:`doe_figure`)."""
    return _png(doe_figure(doe_variants()), dpi=80)


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


def inversion_figure(m: InversionMorphs) -> Any:
    """The MOVE with ``warn`` (inverted elements red) beside the same MOVE with ``clamp``.

    The surface is translucent grey; inverted elements (those the REPORT names) are drawn whole
    in red, poor ones (scaled Jacobian below :data:`POOR_SJ`) in orange.

    Parameters
    ----------
    m : InversionMorphs

    Returns
    -------
    matplotlib.figure.Figure
        Two panels: ``warn``, then ``clamp``.
    """
    plt = _pyplot()
    warn, clamp = m.reports
    every = np.vstack([m.V0, m.V, m.V_clamped])
    lo, hi = every.min(0), every.max(0)
    fig = plt.figure(figsize=(12, 3.2))
    panels = ((m.V, m.sj, m.inverted, f"warn: {move_text(m.move)}, {warn['inverted_elements']} inverted (red)"),
              (m.V_clamped, m.sj_clamped, np.flatnonzero(m.sj_clamped <= 0),
               f"clamp: {clamp['applied_fraction']:.3g} of it applied, {clamp['inverted_elements']} inverted"))
    for i, (V, sj, bad, title) in enumerate(panels):
        ax = fig.add_subplot(1, 2, i + 1, projection="3d")
        poor = np.setdiff1d(np.flatnonzero(sj < POOR_SJ), bad)
        faces = [m.F] + [m.T[e][:, TET_FACES].reshape(-1, 3) for e in (poor, bad)]
        rgba = []
        for F, colour, alpha in zip(faces, (GREY, (1.0, 0.6, 0.1), (0.85, 0.05, 0.05)), (0.25, 0.45, 1.0),
                                    strict=True):
            rgba.append(np.column_stack([_shade(V, F, np.tile(colour, (len(F), 1))), np.full(len(F), alpha)]))
        _surface(ax, V[np.vstack(faces)], np.vstack(rgba))
        _frame(ax, lo, hi, f"{title}; {len(poor)} poor (orange)", 65, -80, zoom=1.2)
    fig.subplots_adjust(left=0, right=1, wspace=0, top=1, bottom=0)
    return fig


def inversion_png() -> bytes:
    """The inversion map and the clamped MOVE beside it (:func:`inversion_figure`)."""
    return _png(inversion_figure(inversion_morphs()))


#: Every picture, by its path under ``docs/``, and the function that solves and draws it.
PICTURES = {"img/tutorial-bracket-displacement.png": bracket_displacement_png,  # tutorials/morph-a-deck.md
            "img/tutorial-sector-cyclic.png": sector_png,  # tutorials/sector-symmetry.md
            "img/tutorial-doe-variants.png": doe_png,  # tutorials/design-study.md
            "img/guide-inversion-clamp.png": inversion_png}  # guide/validity.md


if __name__ == "__main__":
    out = Path(sys.argv[1])
    for uri, make in PICTURES.items():
        (out / uri).parent.mkdir(parents=True, exist_ok=True)
        (out / uri).write_bytes(make())
