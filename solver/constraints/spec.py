"""The parsed SPEC: what is fixed, what moves, how to solve, with its names resolved.

SPEC is a plain JSON-compatible dict, the public contract shared by the
library, the CLI and the REST service, defined once by its model
(:class:`solver.documents.spec.Spec`). :func:`parse_spec` validates a
document with that model (strict: unknown fields, booleans or strings where
numbers belong, non-finite or out-of-range values raise
:class:`~solver.errors.SpecError` naming the field, before any work), then
resolves what the model cannot check on its own: the selection names it
uses and the relations between its entries. The result is a frozen
:class:`ResolvedSpec` whose constraint entries are frozen dataclasses
(:class:`PointEntry`, ...), read by attribute, never by key.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import SpecError
from .edit_kinds import EDIT_KINDS

if TYPE_CHECKING:
    from .edit_entries import EditEntry

__all__ = ["ResolvedSpec", "PointDef", "PointEntry", "RelativeEntry", "FeatureEntry", "MotionEntry", "SlidingEntry",
           "SymmetryEntry", "CyclicEntry", "TargetEntry", "parse_spec", "THIN_WALL_WEIGHT"]

#: Default weight of the thin-wall rows (SPEC "thin_walls": true): the weight with the fewest
#: inverted tets over kiefer_fea_bracket.vtu, Armadillo13K.msh and screw.msh and eight bends
#: each (benchmarks/compare/thin_walls.py: 0 -> 10,518, 0.03 -> 520, 0.1 -> 117, 0.3 -> 3,367, 1 -> 7,403).
THIN_WALL_WEIGHT = 0.1


@dataclass(frozen=True)
class PointDef:
    """A point as a linear combination of vertices, or the centroid of a selection.

    Attributes
    ----------
    vertices : tuple of int
    weights : tuple of float
        One per vertex (edge ``t`` and face barycentric forms become these).
    selection : str or None
        When set, the point is that selection's centroid and ``vertices`` is empty.
    """

    vertices: tuple[int, ...] = ()
    weights: tuple[float, ...] = ()
    selection: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """The point's SPEC form (``vertices`` + ``weights`` or ``selection``)."""
        if self.selection is not None:
            return {"selection": self.selection}
        return {"vertices": list(self.vertices), "weights": list(self.weights)}


@dataclass(frozen=True)
class PointEntry:
    """A point held at a target (``SPEC.points``); ``target`` None means its rest position."""

    name: str
    at: PointDef
    target: tuple[float, float, float] | None = None

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry."""
        out = {"name": self.name, **self.at.to_dict()}
        if self.target is not None:
            out["target"] = list(self.target)
        return out


@dataclass(frozen=True)
class RelativeEntry:
    """``a - b = v`` between two points (``SPEC.relative``; ECLS eq. 28).

    ``mode`` ``"rotate"``: ``v`` is the rest offset turned with the rotation field;
    ``"translate"``: the rest offset itself. A MOVE may give the offset or a scale.
    """

    name: str
    a: PointDef
    b: PointDef
    mode: str = "rotate"

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry (two single vertices keep the ``vertices`` form)."""
        single = all(p.selection is None and len(p.vertices) == 1 and p.weights == (1.0,) for p in (self.a, self.b))
        if single:
            return {"name": self.name, "vertices": [self.a.vertices[0], self.b.vertices[0]], "mode": self.mode}
        return {"name": self.name, "points": [self.a.to_dict(), self.b.to_dict()], "mode": self.mode}


@dataclass(frozen=True)
class FeatureEntry:
    """A form feature (``SPEC.features``): a selection kept rigid or its direction kept."""

    name: str
    selection: str
    mode: str = "rigid"

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry."""
        return {"name": self.name, "selection": self.selection, "mode": self.mode}


@dataclass(frozen=True)
class MotionEntry:
    """A point that moves on a plane (``normal``) or a line (``direction``) through a MOVE-set point."""

    name: str
    at: PointDef
    normal: tuple[float, float, float] | None = None
    direction: tuple[float, float, float] | None = None

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry."""
        out: dict[str, Any] = {"name": self.name, **self.at.to_dict()}
        if self.normal is not None:
            out["plane"] = {"normal": list(self.normal)}
        else:
            out["line"] = {"direction": list(self.direction or ())}
        return out


@dataclass(frozen=True)
class SlidingEntry:
    """Every node of a selection keeps its ``normal`` coordinate (slides in its plane)."""

    selection: str
    normal: tuple[float, float, float]

    @property
    def name(self) -> str:
        """The selection's name (sliding entries are named after it)."""
        return self.selection

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry."""
        return {"selection": self.selection, "normal": list(self.normal)}


@dataclass(frozen=True)
class SymmetryEntry:
    """Mirror symmetry across a plane (``SPEC.symmetry``): ``p_j = M p_i`` for mirrored boundary nodes.

    ``M p = p - 2 n (n . (p - c))``. Each boundary node on the negative side of
    the plane is tied to the mirror image of the positive side (its mirrored
    node, or the point of the positive side's boundary faces nearest to its
    mirror image); nodes on the plane keep their normal coordinate.
    """

    name: str
    point: tuple[float, float, float]
    normal: tuple[float, float, float]
    tolerance: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry."""
        out: dict[str, Any] = {"name": self.name, "plane": {"point": list(self.point), "normal": list(self.normal)}}
        if self.tolerance is not None:
            out["tolerance"] = self.tolerance
        return out


@dataclass(frozen=True)
class CyclicEntry:
    """Cyclic symmetry of a sector (``SPEC.cyclic``): ``p_b = R p_a`` between its two cut faces.

    ``R`` turns by ``angle_deg`` about the axis through ``point`` along
    ``direction``. Every node of face B is tied to the image under ``R`` of
    face A (its matching node, or the nearest point of A's boundary faces).
    """

    name: str
    point: tuple[float, float, float]
    direction: tuple[float, float, float]
    angle_deg: float
    faces: tuple[str, str]
    tolerance: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry."""
        out: dict[str, Any] = {"name": self.name,
                               "axis": {"point": list(self.point), "direction": list(self.direction)},
                               "angle_deg": self.angle_deg, "faces": list(self.faces)}
        if self.tolerance is not None:
            out["tolerance"] = self.tolerance
        return out


@dataclass(frozen=True)
class TargetEntry:
    """A selection whose boundary nodes land on a target surface (``SPEC.targets``).

    ``surface`` is a file path (STL, OBJ, PLY, OFF, any triangle mesh meshio
    reads) or ``{"vertices": [[x, y, z], ...], "triangles": [[i, j, k], ...]}``.
    ``method``: ``closest`` (each node to its closest point) or ``normal``
    (along the node's rest normal, the closest point where no hit is found).
    """

    name: str
    selection: str
    surface: Any
    method: str = "closest"
    tolerance: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry."""
        out: dict[str, Any] = {"name": self.name, "selection": self.selection, "surface": self.surface,
                               "method": self.method}
        if self.tolerance is not None:
            out["tolerance"] = self.tolerance
        return out


@dataclass(frozen=True)
class ResolvedSpec:
    """A parsed SPEC.

    Attributes
    ----------
    selections : dict of str to dict
        Named selections (see :mod:`solver.constraints.selection`).
    fixed : tuple of str
        Selections that keep their rest positions.
    handles : dict of str to str
        Handle name to selection name.
    domain : str or None
        The morph domain: a selection outside which every node (corner and
        mid-side) keeps its rest position, as if fixed (HyperMorph's domains,
        ANSA's morphing boxes). The handles must lie inside it. ``None``: the
        whole mesh morphs.
    laplacian : {"cotangent", "uniform"}
        Weights of the boundary rows (eq. 3.1, or eq. 9 of the ECLS paper).
    method : {"null_space", "kkt", "penalty"}
        Hard constraints by the per-component QR null space (exact), by
        Lagrange multipliers (KKT, exact to round-off), or by the paper's
        penalty weight (approximate; its residual is reported).
    penalty_weight : float
        ``beta`` of eq. (3.8) and (4.2) when ``method == "penalty"``.
    solve : {"auto", "split", "joint"}
        Position solve; ``auto`` picks the split solve where it is exact.
    rotation : {"harmonic", "least_squares"}
        Rotation propagation: harmonic interpolation of quaternion logarithms
        (ECLS eq. 25-27) or the least-squares form of eq. (3.8)/(3.9).
    inversion : {"warn", "reject", "clamp"}
        What an inverting MOVE does: solved and reported, refused, or scaled
        back to its safe fraction (:func:`solver.validity.safe_fraction.safe_fraction`).
    points, relative, features, motion, sliding : tuple of entries
        The further hard constraints (:class:`PointEntry`, :class:`RelativeEntry`,
        :class:`FeatureEntry`, :class:`MotionEntry`, :class:`SlidingEntry`).
    symmetry, cyclic, targets : tuple of entries
        Mirror and cyclic symmetry (:class:`SymmetryEntry`, :class:`CyclicEntry`)
        and target surfaces (:class:`TargetEntry`).
    edits : tuple of entries
        The daily edits, ``radius``, ``twist``, ``map``, ``offset`` and ``lattice`` entries in that
        order (:mod:`solver.constraints.edit_entries`): selections whose nodes get positions
        computed from their rest positions and the MOVE's parameters.
    conflicts : {"report", "reject"}
        What a conflicting constraint does: reported in the REPORT, or the
        SPEC (and any MOVE) that makes constraints conflict is refused.
    repair : bool
        Untangle inverted elements after each solve by moving free interior
        vertices near them (:mod:`solver.validity.repair`).
    ties : "auto", False, {"tolerance": t, "surface": [[A, B], ...], "surface_tolerance": s} or list of [i, j]
        Hard ties ``p_i = p_j`` (and equal rotations) between coincident nodes of
        different bodies (assemblies); ``"auto"`` finds them within 1e-9 of the
        diagonal. ``surface`` pairs of selections tie every boundary node of A
        to its closest point on B's boundary faces (non-matching interfaces),
        next to the coincident-node ties.
    voids : {"volume", "refuse"}
        An internal void (a boundary shell with no fixed or handle vertex):
        positioned by the surrounding volume, or refused.
    solve_options : dict
        What the SPEC asks of the solve (``backend``, ``precision``, ``threads``,
        ``sweeps``, ``basis``; its ``precision`` is here too): laid over the
        caller's :class:`~solver.options.SolveOptions` by
        :meth:`~solver.options.SolveOptions.updated` at precompute. ``mixed``
        precision factors the interior mean-value system in single precision
        (half the bytes per update), checks the double-precision residual and
        refines once when it exceeds :data:`~solver.deform.positions.MIXED_TOL`;
        the REPORT states the residual. ``exact`` keeps a double-precision factor.
        Hard constraints are exact either way.
    thin_walls : float
        Weight of the rows that tie the two faces of walls one tet thick
        (default ``THIN_WALL_WEIGHT``; 0 is the paper's method unchanged), see
        :mod:`solver.deform.thin_walls`.
    """

    selections: dict[str, dict[str, Any]]
    fixed: tuple[str, ...] = ()
    handles: dict[str, str] = field(default_factory=dict)
    domain: str | None = None
    laplacian: str = "cotangent"
    method: str = "null_space"
    penalty_weight: float = 1.0e4
    solve: str = "auto"
    rotation: str = "harmonic"
    inversion: str = "warn"
    points: tuple[PointEntry, ...] = ()
    relative: tuple[RelativeEntry, ...] = ()
    features: tuple[FeatureEntry, ...] = ()
    motion: tuple[MotionEntry, ...] = ()
    sliding: tuple[SlidingEntry, ...] = ()
    symmetry: tuple[SymmetryEntry, ...] = ()
    cyclic: tuple[CyclicEntry, ...] = ()
    targets: tuple[TargetEntry, ...] = ()
    conflicts: str = "report"
    repair: bool = False
    thin_walls: float = THIN_WALL_WEIGHT
    ties: Any = "auto"
    voids: str = "volume"
    solve_options: dict[str, Any] = field(default_factory=dict)
    edits: tuple[EditEntry, ...] = ()

    @property
    def names(self) -> dict[str, tuple[str, ...]]:
        """Names a MOVE may address, per category (``points``, ..., ``targets`` and each edit kind)."""
        out = {k: tuple(e.name for e in getattr(self, k))
               for k in ("points", "relative", "features", "motion", "targets")}
        out.update({k: tuple(e.name for e in self.edits if e.kind == k) for k in EDIT_KINDS})
        return out

    def to_dict(self) -> dict[str, Any]:
        """Return the SPEC as a JSON-compatible dict."""
        out = {
            "selections": self.selections, "fixed": list(self.fixed), "handles": dict(self.handles),
            "laplacian": self.laplacian,
            "constraints": {"method": self.method, "penalty_weight": self.penalty_weight},
            "solve": self.solve, "rotation": self.rotation, "inversion": self.inversion,
            "conflicts": self.conflicts, "repair": self.repair,
            "thin_walls": {"weight": self.thin_walls} if self.thin_walls > 0 else False,
            "ties": self.ties, "voids": self.voids,
        }
        if self.solve_options:
            out["solve_options"] = dict(self.solve_options)
        if self.domain is not None:
            out["domain"] = self.domain
        for key in ("points", "relative", "features", "motion", "sliding", "symmetry", "cyclic", "targets"):
            if getattr(self, key):
                out[key] = [e.to_dict() for e in getattr(self, key)]
        for e in self.edits:
            out.setdefault(e.kind, []).append(e.to_dict())
        return out


# ------------------------------------------------------------------ relations
def expect(cond: bool, msg: str, **details: Any) -> None:
    """Raise :class:`SpecError` with ``msg`` and ``details`` unless ``cond``."""
    if not cond:
        raise SpecError(msg, **details)


def _unit(v: list[float]) -> tuple[float, float, float]:
    """``v`` scaled to unit length (the model refused a zero vector)."""
    a = np.asarray(v, np.float64)
    x, y, z = (a / np.linalg.norm(a)).tolist()
    return (x, y, z)


def parse_spec(doc: Any) -> ResolvedSpec:
    """Parse and validate a SPEC document.

    The document is validated by its one model (:class:`solver.documents.spec.Spec`: types, ranges,
    the forms of selections, POINTs and constraints); this function then resolves what the model
    cannot see on its own: the names it uses for selections, and the relations between its entries.

    Parameters
    ----------
    doc : dict or solver.documents.spec.Spec
        The document (file paths allowed for target surfaces), or an instance of the model the
        caller has validated already (the service's request bodies): it is not validated again.
        docs/guide/constraints.md gives each form.

    Returns
    -------
    ResolvedSpec

    Raises
    ------
    SpecError
        What the model refuses (unknown fields, booleans or strings where numbers belong,
        non-finite or out-of-range values, a POINT with two forms, ...), names that are not
        selections, a selection used both as fixed and as a handle, two handles on one selection,
        a constraint name used twice in one list, a penalty method with the split solve, or
        ``precision`` and ``solve_options.precision`` that disagree.

    Examples
    --------
    >>> s = parse_spec({"selections": {"a": {"ids": [0]}, "b": {"ids": [1]}},
    ...                 "fixed": ["a"], "handles": {"h": "b"}})
    >>> s.handles, s.method
    ({'h': 'b'}, 'null_space')
    """
    from ..documents.spec import Spec as SpecDoc
    from ..documents.validation import validated

    model = validated(SpecDoc, doc, "SPEC", context={"files": True})
    d = model.dump()
    selections = {str(k): v for k, v in d["selections"].items()}

    def known(name: str, where: str, field: str | None = None) -> str:
        expect(name in selections, f"{where}: unknown selection {name!r}; defined: {sorted(selections)}",
               field=field or where, name=name)
        return name

    fixed, handles = list(model.fixed), dict(model.handles)
    for name in [*fixed, *handles.values()]:
        known(name, "SPEC", "selections")
    both = sorted(set(fixed) & set(handles.values()))
    expect(not both, f"selection(s) {both} are both fixed and a handle", field="handles", names=both)
    used = list(handles.values())
    dup = sorted({s for s in used if used.count(s) > 1})
    expect(not dup, f"selection(s) {dup} drive more than one handle", field="handles", names=dup)
    edits: tuple[EditEntry, ...] = ()
    if any(d.get(kind) for kind in EDIT_KINDS):  # the edits' modules load for a SPEC that names one
        from .edit_entries import edit_entries

        edits = edit_entries(d, known)
    expect(len(fixed) + len(handles) + len(edits) > 0, "SPEC needs at least one fixed selection, handle or edit "
           "(radius, twist, map, offset, lattice, fillet, distance, angle)", field="fixed")
    expect(model.domain is None or model.domain in selections,
           f"SPEC.domain must name a selection; got {model.domain!r}, defined: {sorted(selections)}", field="domain")
    cons = model.constraints
    method = cons.method if cons is not None else "null_space"
    beta = cons.penalty_weight if cons is not None else 1.0e4
    expect(not (method == "penalty" and model.solve == "split"),
           "SPEC.solve 'split' needs exact constraints (constraints.method 'null_space' or 'kkt')", field="solve")
    tw = model.thin_walls
    weight = (THIN_WALL_WEIGHT if tw else 0.0) if isinstance(tw, bool) else tw.weight
    ties = d.get("ties", "auto")
    if isinstance(ties, dict):
        for k, pair in enumerate(ties.get("surface") or []):
            for nm in pair:
                known(nm, f"SPEC.ties.surface[{k}]", "ties.surface")
    solve = model.solve_options.given() if model.solve_options is not None else {}
    if "precision" in d:
        solve["precision"] = d["precision"]
    return ResolvedSpec(selections=selections, fixed=tuple(fixed), handles={str(k): v for k, v in handles.items()},
                domain=model.domain, laplacian=model.laplacian, method=method, penalty_weight=beta,
                solve=model.solve, rotation=model.rotation, inversion=model.inversion, conflicts=model.conflicts,
                repair=model.repair, thin_walls=float(weight), ties=ties, voids=model.voids,
                solve_options=solve, edits=edits, **_entries(d, known))


def _point(e: dict[str, Any], where: str, known: Callable[..., str]) -> PointDef:
    """A POINT of the validated document: ``vertices`` (+ ``weights``), ``edge`` + ``t``, ``face`` + ``barycentric``."""
    if "selection" in e:
        return PointDef(selection=known(e["selection"], f"{where}.selection", where))
    if "edge" in e:
        return PointDef(tuple(e["edge"]), (e["t"], 1.0 - e["t"]))
    if "face" in e:
        return PointDef(tuple(e["face"]), tuple(e["barycentric"]))
    ids = e["vertices"]
    return PointDef(tuple(ids), tuple(e.get("weights") or [1.0 / len(ids)] * len(ids)))


def _named(entries: list[Any], key: str) -> tuple[Any, ...]:
    names = [e.name for e in entries]
    dup = sorted({n for n in names if names.count(n) > 1})
    expect(not dup, f"SPEC.{key}: name(s) {dup} used twice", field=key, names=dup)
    return tuple(entries)


def _entries(d: dict[str, Any], known: Callable[..., str]) -> dict[str, Any]:
    """The SPEC's constraint lists as frozen entries, their selection names resolved."""
    def each(key: str) -> list[tuple[str, dict[str, Any]]]:
        return [(f"SPEC.{key}[{k}]", e) for k, e in enumerate(d.get(key) or [])]

    pts = [PointEntry(e["name"], _point(e, w, known), tuple(e["target"]) if e.get("target") else None)
           for w, e in each("points")]
    rel = []
    for w, e in each("relative"):
        if "vertices" in e:
            i, j = e["vertices"]
            a, b = PointDef((i,), (1.0,)), PointDef((j,), (1.0,))
        else:
            a, b = (_point(p, f"{w}.points[{q}]", known) for q, p in enumerate(e["points"]))
        rel.append(RelativeEntry(e["name"], a, b, e.get("mode", "rotate")))
    feats = [FeatureEntry(e.get("name") or e["selection"], known(e["selection"], f"{w}.selection", w),
                          e.get("mode", "rigid")) for w, e in each("features")]
    mot = [MotionEntry(e["name"], _point(e, w, known),
                       normal=_unit(e["plane"]["normal"]) if "plane" in e else None,
                       direction=_unit(e["line"]["direction"]) if "line" in e else None)
           for w, e in each("motion")]
    sl = [SlidingEntry(known(e["selection"], f"{w}.selection", w), _unit(e["normal"])) for w, e in each("sliding")]
    sym = [SymmetryEntry(e["name"], tuple(e["plane"]["point"]), _unit(e["plane"]["normal"]), e.get("tolerance"))
           for w, e in each("symmetry")]
    cyc = []
    for w, e in each("cyclic"):
        faces = e["faces"]
        for nm in faces:
            known(nm, f"{w}.faces", f"{w}.faces")
        cyc.append(CyclicEntry(e["name"], tuple(e["axis"]["point"]), _unit(e["axis"]["direction"]),
                               math.fmod(e["angle_deg"], 360.0), (faces[0], faces[1]), e.get("tolerance")))
    tgs = []
    for w, e in each("targets"):
        surf = e["surface"]
        expect(not (isinstance(surf, dict) and "mesh_id" in surf), f"{w}.surface: a stored surface (mesh_id) is "
               "resolved by the service; the library takes a file path or vertices and triangles",
               field=f"{w}.surface")
        expect(not isinstance(surf, str) or surf != "", f"{w}.surface must be a file path or "
               "{\"vertices\", \"triangles\"}", field=f"{w}.surface")
        tgs.append(TargetEntry(e["name"], known(e["selection"], f"{w}.selection", w), surf,
                               e.get("method", "closest"), e.get("tolerance")))
    return {"points": _named(pts, "points"), "relative": _named(rel, "relative"),
            "features": _named(feats, "features"), "motion": _named(mot, "motion"), "sliding": tuple(sl),
            "symmetry": _named(sym, "symmetry"), "cyclic": _named(cyc, "cyclic"), "targets": _named(tgs, "targets")}
