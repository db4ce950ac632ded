"""The SPEC document: what is fixed, what moves, how to solve.

SPEC is a plain JSON-compatible dict, the public contract shared by the
library, the CLI and the REST service. :func:`parse_spec` is strict: unknown
fields, unknown names, booleans or strings where numbers belong and
non-finite or out-of-range values raise :class:`~solver.errors.SpecError`
naming the field, before any work. The result is a frozen :class:`Spec`
whose constraint entries are frozen dataclasses (:class:`PointEntry`, ...),
read by attribute, never by key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import SpecError
from ..limits import ANGLE_MAX, COORD_MAX, ID_MAX, PENALTY_MAX, POINT_WEIGHT_MAX, WALL_WEIGHT_MAX
from ..linalg.constrained import METHODS as _SOLVERS

__all__ = ["Spec", "PointDef", "PointEntry", "RelativeEntry", "FeatureEntry", "MotionEntry", "SlidingEntry",
           "SymmetryEntry", "CyclicEntry", "TargetEntry",
           "parse_spec", "SOLVE_MODES", "METHODS", "LAPLACIANS", "ROTATIONS", "INVERSION_POLICIES",
           "CONFLICT_POLICIES", "FEATURE_MODES", "RELATIVE_MODES", "MAX_PENALTY_WEIGHT", "MAX_ID"]

LAPLACIANS = ("cotangent", "uniform")
#: The constrained-quadratic methods, by name (:data:`solver.linalg.constrained.METHODS`).
METHODS = tuple(_SOLVERS)
CONFLICT_POLICIES = ("report", "reject")
#: Default weight of the thin-wall rows (SPEC "thin_walls": true): the weight with the fewest
#: inverted tets over kiefer_fea_bracket.vtu, Armadillo13K.msh and screw.msh and eight bends
#: each (benchmarks/compare/thin_walls.py: 0 -> 10,518, 0.03 -> 520, 0.1 -> 117, 0.3 -> 3,367, 1 -> 7,403).
THIN_WALL_WEIGHT = 0.1
FEATURE_MODES = ("rigid", "keep_direction")
RELATIVE_MODES = ("rotate", "translate")
SOLVE_MODES = ("auto", "split", "joint")
ROTATIONS = ("harmonic", "least_squares")
INVERSION_POLICIES = ("warn", "reject", "clamp")
#: Interior solve precision: a single-precision factor with a double-precision residual check
#: (and one refinement step when it is not met), or the double-precision factor.
PRECISIONS = ("mixed", "exact")
SELECTION_KINDS = ("ids", "set", "box", "sphere", "plane")
#: The documents' bounds, defined once in :mod:`solver.limits` (the service's schema reads them too).
MAX_PENALTY_WEIGHT = PENALTY_MAX
MAX_WALL_WEIGHT = WALL_WEIGHT_MAX
MAX_ID = ID_MAX
#: Coordinates (box corners, centres, points, targets, radii, tolerances) are refused beyond this magnitude.
MAX_COORDINATE = COORD_MAX


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
class Spec:
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
    precision : {"mixed", "exact"}
        The split solve's interior mean-value system: ``mixed`` factors it in
        single precision (half the bytes per update), checks the double-precision
        residual and refines once when it exceeds
        :data:`~solver.deform.positions.MIXED_TOL`; the REPORT states the
        residual. ``exact`` keeps a double-precision factor. Hard constraints
        are exact either way.
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
    precision: str = "mixed"

    @property
    def names(self) -> dict[str, tuple[str, ...]]:
        """Names a MOVE may address, per category (``points``, ``relative``, ``features``, ``motion``)."""
        return {k: tuple(e.name for e in getattr(self, k))
                for k in ("points", "relative", "features", "motion", "targets")}

    def to_dict(self) -> dict[str, Any]:
        """Return the SPEC as a JSON-compatible dict."""
        out = {
            "selections": self.selections, "fixed": list(self.fixed), "handles": dict(self.handles),
            "laplacian": self.laplacian,
            "constraints": {"method": self.method, "penalty_weight": self.penalty_weight},
            "solve": self.solve, "rotation": self.rotation, "inversion": self.inversion,
            "conflicts": self.conflicts, "repair": self.repair,
            "thin_walls": {"weight": self.thin_walls} if self.thin_walls > 0 else False,
            "ties": self.ties, "voids": self.voids, "precision": self.precision,
        }
        if self.domain is not None:
            out["domain"] = self.domain
        for key in ("points", "relative", "features", "motion", "sliding", "symmetry", "cyclic", "targets"):
            if getattr(self, key):
                out[key] = [e.to_dict() for e in getattr(self, key)]
        return out


# ------------------------------------------------------------------ value checks
def expect(cond: bool, msg: str, **details: Any) -> None:
    """Raise :class:`SpecError` with ``msg`` and ``details`` unless ``cond``."""
    if not cond:
        raise SpecError(msg, **details)


def is_number(x: Any) -> bool:
    """True for an int or float that is not a bool (JSON numbers only)."""
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def number(x: Any, where: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    """A finite JSON number in ``[lo, hi]``, as float; else a SpecError naming ``where``.

    Examples
    --------
    >>> number(2, "scale")
    2.0
    >>> number(True, "scale")
    Traceback (most recent call last):
    ...
    solver.errors.SpecError: scale must be a number, got True
    """
    expect(is_number(x), f"{where} must be a number, got {x!r}", field=where)
    try:
        v = float(x)
    except OverflowError:
        raise SpecError(f"{where} is too large: {x!r}", field=where) from None
    expect(math.isfinite(v), f"{where} must be finite, got {x!r}", field=where)
    expect(lo <= v <= hi, f"{where} must be in [{lo:g}, {hi:g}], got {v:g}", field=where, value=v)
    return v


def vec3(x: Any, where: str, bound: float = MAX_COORDINATE) -> np.ndarray:
    """Three finite JSON numbers with ``|x_i| <= bound``, as a (3,) float array."""
    expect(isinstance(x, (list, tuple)) and len(x) == 3 and all(is_number(v) for v in x),
           f"{where} must be 3 numbers, got {x!r}", field=where)
    return np.array([number(v, where, -bound, bound) for v in x])


def check_keys(d: Any, allowed: tuple[str, ...], where: str) -> None:
    """``d`` is an object whose keys are all in ``allowed``."""
    expect(isinstance(d, dict), f"{where} must be an object, got {type(d).__name__}", field=where)
    unknown = sorted(str(k) for k in set(d) - set(allowed))
    expect(not unknown, f"unknown field(s) {unknown} in {where}; allowed: {list(allowed)}",
           field=where, unknown=unknown)


def int_list(x: Any, where: str, length: int | None = None) -> list[int]:
    """A non-empty list of distinct int64 vertex ids (range against the mesh is checked later)."""
    ok = isinstance(x, list) and len(x) > 0 and all(isinstance(i, int) and not isinstance(i, bool) for i in x)
    expect(ok, f"{where} must be a non-empty list of vertex indices, got {x!r}", field=where)
    big = [i for i in x if not 0 <= i <= MAX_ID]
    expect(not big, f"{where}: vertex ids {big[:5]} are negative or exceed int64", field=where)
    if length is not None:
        expect(len(x) == length, f"{where} must have {length} vertex indices, got {len(x)}", field=where)
    expect(len(set(x)) == len(x), f"{where} repeats a vertex: {x!r}", field=where)
    return list(x)


def nonzero(v: np.ndarray, where: str) -> np.ndarray:
    """``v`` scaled to unit length; refuses a zero or subnormal vector."""
    n = float(np.linalg.norm(v))
    expect(math.isfinite(n) and n > 1e-150, f"{where} must be non-zero, got {v.tolist()}", field=where)
    return v / n


def _check_selection(name: str, sel: Any) -> dict[str, Any]:
    where = f"selections.{name}"
    check_keys(sel, (*SELECTION_KINDS, "boundary_only"), where)
    kinds = [k for k in sel if k in SELECTION_KINDS]
    expect(len(kinds) == 1, f"{where} must have exactly one of {list(SELECTION_KINDS)}", field=where)
    expect(isinstance(sel.get("boundary_only", False), bool),
           f"{where}.boundary_only must be true or false", field=where)
    kind = kinds[0]
    val = sel[kind]
    if kind == "ids":
        expect(isinstance(val, list) and all(isinstance(i, int) and not isinstance(i, bool) for i in val),
               f"{where}.ids must be a list of integers", field=where)
        big = [i for i in val if not 0 <= i <= MAX_ID]
        expect(not big, f"{where}.ids: {big[:5]} are negative or exceed int64", field=where)
    elif kind == "set":
        expect(isinstance(val, str), f"{where}.set must be a set name", field=where)
    elif kind == "box":
        check_keys(val, ("min", "max"), f"{where}.box")
        lo = vec3(val.get("min"), f"{where}.box.min")
        hi = vec3(val.get("max"), f"{where}.box.max")
        expect(bool(np.all(lo <= hi)), f"{where}.box: min {lo.tolist()} exceeds max {hi.tolist()}", field=where)
    elif kind == "sphere":
        check_keys(val, ("center", "radius"), f"{where}.sphere")
        vec3(val.get("center"), f"{where}.sphere.center")
        number(val.get("radius"), f"{where}.sphere.radius", 0.0, MAX_COORDINATE)
    elif kind == "plane":
        check_keys(val, ("point", "normal", "tolerance"), f"{where}.plane")
        vec3(val.get("point"), f"{where}.plane.point")
        nonzero(vec3(val.get("normal"), f"{where}.plane.normal"), f"{where}.plane.normal")
        number(val.get("tolerance", 0.0), f"{where}.plane.tolerance", 0.0, MAX_COORDINATE)
    return sel


def parse_spec(doc: Any) -> Spec:
    """Parse and validate a SPEC document.

    Parameters
    ----------
    doc : dict or solver.documents.spec.Spec
        The document, validated first by its model (:class:`solver.documents.spec.Spec`, with file
        paths allowed for target surfaces), or an instance of that model:
        ``{"selections": {...}, "fixed": [...], "handles": {...}, "laplacian": ...,
        "constraints": {"method": ..., "penalty_weight": ...}, "solve": ...,
        "rotation": ..., "inversion": ..., "points": [...], "relative": [...],
        "features": [...], "motion": [...], "sliding": [...], "conflicts": ...}``;
        docs/guide/constraints.md gives each form.

    Returns
    -------
    Spec

    Raises
    ------
    SpecError
        Unknown fields, names that are not selections, bad values (a boolean or
        a string where a number belongs, non-finite numbers, ids beyond int64,
        a penalty weight above ``MAX_PENALTY_WEIGHT``), a selection used both
        as fixed and as a handle, two handles on one selection, or a
        constraint name used twice in one list.

    Examples
    --------
    >>> s = parse_spec({"selections": {"a": {"ids": [0]}, "b": {"ids": [1]}},
    ...                 "fixed": ["a"], "handles": {"h": "b"}})
    >>> s.handles, s.method
    ({'h': 'b'}, 'null_space')
    """
    from ..documents.spec import Spec as SpecDoc
    from ..documents.validation import validated

    if isinstance(doc, SpecDoc):  # validated by its caller (the service's request bodies)
        doc = doc.dump()
    else:  # types and static ranges, from the one definition; names and relations below
        validated(SpecDoc, doc, "SPEC", context={"files": True})
    check_keys(doc, ("selections", "fixed", "handles", "domain", "laplacian", "constraints", "solve",
                     "rotation", "inversion", "points", "relative", "features", "motion", "sliding",
                     "symmetry", "cyclic", "targets", "conflicts", "repair", "thin_walls", "ties", "voids",
                     "precision"), "SPEC")
    sels = doc.get("selections", {})
    expect(isinstance(sels, dict) and len(sels) > 0, "SPEC.selections must name at least one selection",
           field="selections")
    selections = {str(k): _check_selection(str(k), v) for k, v in sels.items()}
    fixed = doc.get("fixed", [])
    expect(isinstance(fixed, list) and all(isinstance(f, str) for f in fixed),
           "SPEC.fixed must be a list of selection names", field="fixed")
    handles = doc.get("handles", {})
    expect(isinstance(handles, dict) and all(isinstance(v, str) for v in handles.values()),
           "SPEC.handles must map handle names to selection names", field="handles")
    for name in [*fixed, *handles.values()]:
        expect(name in selections, f"unknown selection {name!r}; defined: {sorted(selections)}",
               field="selections", name=name)
    both = sorted(set(fixed) & set(handles.values()))
    expect(not both, f"selection(s) {both} are both fixed and a handle", field="handles", names=both)
    domain = doc.get("domain")
    expect(domain is None or (isinstance(domain, str) and domain in selections),
           f"SPEC.domain must name a selection; got {domain!r}, defined: {sorted(selections)}", field="domain")
    used = list(handles.values())
    dup = sorted({s for s in used if used.count(s) > 1})
    expect(not dup, f"selection(s) {dup} drive more than one handle", field="handles", names=dup)
    expect(len(fixed) + len(handles) > 0, "SPEC needs at least one fixed selection or handle", field="fixed")
    extra = _parse_constraint_lists(doc, selections)
    cons = doc.get("constraints", {})
    check_keys(cons, ("method", "penalty_weight"), "SPEC.constraints")
    method = cons.get("method", "null_space")
    expect(method in METHODS, f"SPEC.constraints.method must be one of {list(METHODS)}, got {method!r}",
           field="constraints.method")
    beta = number(cons.get("penalty_weight", 1.0e4), "SPEC.constraints.penalty_weight")
    expect(beta > 0, "SPEC.constraints.penalty_weight must be > 0", field="constraints.penalty_weight")
    beta = number(beta, "SPEC.constraints.penalty_weight", 0.0, MAX_PENALTY_WEIGHT)
    out: dict[str, Any] = {}
    for key, allowed, default in (("laplacian", LAPLACIANS, "cotangent"), ("solve", SOLVE_MODES, "auto"),
                                  ("rotation", ROTATIONS, "harmonic"),
                                  ("inversion", INVERSION_POLICIES, "warn"),
                                  ("conflicts", CONFLICT_POLICIES, "report"),
                                  ("voids", ("volume", "refuse"), "volume"),
                                  ("precision", PRECISIONS, "mixed")):
        val = doc.get(key, default)
        expect(isinstance(val, str) and val in allowed, f"SPEC.{key} must be one of {list(allowed)}, got {val!r}",
               field=key)
        out[key] = val
    repair = doc.get("repair", False)
    expect(isinstance(repair, bool), f"SPEC.repair must be true or false, got {repair!r}", field="repair")
    out["repair"] = repair
    tw = doc.get("thin_walls", True)
    if isinstance(tw, bool):
        tw = THIN_WALL_WEIGHT if tw else 0.0
    else:
        expect(isinstance(tw, dict) and set(tw) <= {"weight"}, "SPEC.thin_walls must be true, false or "
               "{\"weight\": w}", field="thin_walls")
        tw = number(tw.get("weight", 1.0), "SPEC.thin_walls.weight", 0.0, MAX_WALL_WEIGHT)
    out["thin_walls"] = float(tw)
    ties = doc.get("ties", "auto")
    if isinstance(ties, dict):
        check_keys(ties, ("tolerance", "surface", "surface_tolerance"), "SPEC.ties")
        expect("tolerance" in ties or "surface" in ties, "SPEC.ties needs a tolerance or surface pairs", field="ties")
        if "tolerance" in ties:
            number(ties["tolerance"], "SPEC.ties.tolerance", 0.0, MAX_COORDINATE)
        if "surface_tolerance" in ties:
            number(ties["surface_tolerance"], "SPEC.ties.surface_tolerance", 0.0, MAX_COORDINATE)
        pairs = ties.get("surface", [])
        expect(isinstance(pairs, list) and all(isinstance(p, list) and len(p) == 2 for p in pairs),
               "SPEC.ties.surface must be a list of [SELECTION_A, SELECTION_B] pairs", field="ties.surface")
        for k, (a, b) in enumerate(pairs):
            for nm in (a, b):
                expect(isinstance(nm, str) and nm in selections, f"SPEC.ties.surface[{k}]: unknown selection "
                       f"{nm!r}; defined: {sorted(selections)}", field="ties.surface")
    elif isinstance(ties, list):
        for k, pair in enumerate(ties):
            int_list(pair, f"SPEC.ties[{k}]", 2)
    else:
        expect(ties == "auto" or ties is False, "SPEC.ties must be \"auto\", false, {\"tolerance\": t} or a "
               "list of [i, j] vertex pairs", field="ties")
    out["ties"] = ties
    expect(not (method == "penalty" and out["solve"] == "split"),
           "SPEC.solve 'split' needs exact constraints (constraints.method 'null_space' or 'kkt')", field="solve")
    return Spec(selections=selections, fixed=tuple(fixed), handles={str(k): v for k, v in handles.items()},
                domain=domain, method=method, penalty_weight=beta, **out, **extra)


POINT_FIELDS = ("vertices", "weights", "edge", "t", "face", "barycentric", "selection")


def point_def(e: dict[str, Any], where: str, selections: dict[str, Any]) -> PointDef:
    """A POINT: ``vertices`` (+ ``weights``), ``edge`` + ``t``, ``face`` + ``barycentric`` or ``selection``."""
    forms = [k for k in ("vertices", "edge", "face", "selection") if k in e]
    expect(len(forms) == 1, f"{where} must give exactly one of vertices+weights, edge+t, "
           "face+barycentric or selection", field=where)
    form = forms[0]
    if form == "selection":
        expect(isinstance(e["selection"], str) and e["selection"] in selections,
               f"{where}.selection: unknown selection {e['selection']!r}; defined: {sorted(selections)}", field=where)
        expect("weights" not in e, f"{where}: a selection point is its centroid; no weights", field=where)
        return PointDef(selection=e["selection"])
    if form == "edge":
        ids = int_list(e["edge"], f"{where}.edge", 2)
        t = number(e.get("t"), f"{where}.t", 0.0, 1.0)
        return PointDef(tuple(ids), (t, 1.0 - t))
    if form == "face":
        ids = int_list(e["face"], f"{where}.face", 3)
        bary = e.get("barycentric", [])
        expect(isinstance(bary, list) and len(bary) == 3, f"{where}.barycentric must be 3 numbers", field=where)
        w = [number(x, f"{where}.barycentric", 0.0, 1.0) for x in bary]
        expect(abs(sum(w) - 1.0) <= 1e-9, f"{where}.barycentric must sum to 1, got {w}", field=where)
        return PointDef(tuple(ids), tuple(w))
    ids = int_list(e["vertices"], f"{where}.vertices")
    w = e.get("weights", [1.0 / len(ids)] * len(ids))
    expect(isinstance(w, list) and len(w) == len(ids), f"{where}.weights must be {len(ids)} numbers "
           "(one per vertex)", field=where)
    w = [number(x, f"{where}.weights", -POINT_WEIGHT_MAX, POINT_WEIGHT_MAX) for x in w]
    expect(abs(sum(w)) > 1e-12, f"{where}.weights must not sum to zero", field=where)
    return PointDef(tuple(ids), tuple(w))


def _names(entries: list[Any], key: str) -> None:
    names = [e.name for e in entries]
    dup = sorted({n for n in names if names.count(n) > 1})
    expect(not dup, f"SPEC.{key}: name(s) {dup} used twice", field=key, names=dup)


def _name(e: dict[str, Any], where: str) -> str:
    expect(isinstance(e.get("name"), str), f"{where}.name must be a string", field=where)
    return str(e["name"])


def _parse_constraint_lists(doc: dict[str, Any], selections: dict[str, Any]) -> dict[str, Any]:
    """Parse SPEC ``points``, ``relative``, ``features``, ``motion`` and ``sliding``."""
    lists = {}
    for key in ("points", "relative", "features", "motion", "sliding"):
        val = doc.get(key, [])
        expect(isinstance(val, list), f"SPEC.{key} must be a list", field=key)
        lists[key] = val
    pts = []
    for k, e in enumerate(lists["points"]):
        where = f"SPEC.points[{k}]"
        check_keys(e, ("name", *POINT_FIELDS, "target"), where)
        tgt = tuple(vec3(e["target"], f"{where}.target").tolist()) if "target" in e else None
        pts.append(PointEntry(_name(e, where), point_def(e, where, selections), tgt))  # type: ignore[arg-type]
    _names(pts, "points")
    rel = []
    for k, e in enumerate(lists["relative"]):
        where = f"SPEC.relative[{k}]"
        check_keys(e, ("name", "vertices", "points", "mode"), where)
        name = _name(e, where)
        mode = e.get("mode", "rotate")
        expect(mode in RELATIVE_MODES, f"{where}.mode must be one of {list(RELATIVE_MODES)}", field=where)
        expect(("vertices" in e) != ("points" in e), f"{where} needs exactly one of vertices [i, j] or "
               "points [POINT, POINT]", field=where)
        if "vertices" in e:
            i, j = int_list(e.get("vertices"), f"{where}.vertices", 2)
            a, b = PointDef((i,), (1.0,)), PointDef((j,), (1.0,))
        else:
            p = e["points"]
            expect(isinstance(p, list) and len(p) == 2, f"{where}.points must be two POINTs", field=where)
            for q, sub in enumerate(p):
                check_keys(sub, POINT_FIELDS, f"{where}.points[{q}]")
            a, b = (point_def(p[q], f"{where}.points[{q}]", selections) for q in range(2))
        rel.append(RelativeEntry(name, a, b, mode))
    _names(rel, "relative")
    feats = []
    for k, e in enumerate(lists["features"]):
        where = f"SPEC.features[{k}]"
        check_keys(e, ("name", "selection", "mode"), where)
        expect(isinstance(e.get("selection"), str) and e.get("selection") in selections,
               f"{where}.selection: unknown selection {e.get('selection')!r}; defined: {sorted(selections)}",
               field=where)
        mode = e.get("mode", "rigid")
        expect(mode in FEATURE_MODES, f"{where}.mode must be one of {list(FEATURE_MODES)}", field=where)
        name = e.get("name", e["selection"])
        expect(isinstance(name, str), f"{where}.name must be a string", field=where)
        feats.append(FeatureEntry(name, e["selection"], mode))
    _names(feats, "features")
    mot = []
    for k, e in enumerate(lists["motion"]):
        where = f"SPEC.motion[{k}]"
        check_keys(e, ("name", *POINT_FIELDS, "plane", "line"), where)
        name = _name(e, where)
        at = point_def(e, where, selections)
        expect(("plane" in e) != ("line" in e), f"{where} needs exactly one of plane or line", field=where)
        if "plane" in e:
            check_keys(e["plane"], ("normal",), f"{where}.plane")
            nrm = nonzero(vec3(e["plane"].get("normal"), f"{where}.plane.normal"), f"{where}.plane.normal")
            mot.append(MotionEntry(name, at, normal=tuple(nrm.tolist())))  # type: ignore[arg-type]
        else:
            check_keys(e["line"], ("direction",), f"{where}.line")
            t = nonzero(vec3(e["line"].get("direction"), f"{where}.line.direction"), f"{where}.line.direction")
            mot.append(MotionEntry(name, at, direction=tuple(t.tolist())))  # type: ignore[arg-type]
    _names(mot, "motion")
    sl = []
    for k, e in enumerate(lists["sliding"]):
        where = f"SPEC.sliding[{k}]"
        check_keys(e, ("selection", "normal"), where)
        expect(isinstance(e.get("selection"), str) and e.get("selection") in selections,
               f"{where}.selection: unknown selection {e.get('selection')!r}; defined: {sorted(selections)}",
               field=where)
        nrm = nonzero(vec3(e.get("normal"), f"{where}.normal"), f"{where}.normal")
        sl.append(SlidingEntry(e["selection"], tuple(nrm.tolist())))  # type: ignore[arg-type]
    sym = []
    for k, e in enumerate(_list(doc, "symmetry")):
        where = f"SPEC.symmetry[{k}]"
        check_keys(e, ("name", "plane", "tolerance"), where)
        check_keys(e.get("plane"), ("point", "normal"), f"{where}.plane")
        c = vec3(e["plane"].get("point"), f"{where}.plane.point")
        nrm = nonzero(vec3(e["plane"].get("normal"), f"{where}.plane.normal"), f"{where}.plane.normal")
        tol = number(e["tolerance"], f"{where}.tolerance", 0.0, MAX_COORDINATE) if "tolerance" in e else None
        sym.append(SymmetryEntry(_name(e, where), tuple(c.tolist()), tuple(nrm.tolist()), tol))  # type: ignore
    _names(sym, "symmetry")
    cyc = []
    for k, e in enumerate(_list(doc, "cyclic")):
        where = f"SPEC.cyclic[{k}]"
        check_keys(e, ("name", "axis", "angle_deg", "faces", "tolerance"), where)
        check_keys(e.get("axis"), ("point", "direction"), f"{where}.axis")
        c = vec3(e["axis"].get("point"), f"{where}.axis.point")
        t = nonzero(vec3(e["axis"].get("direction"), f"{where}.axis.direction"), f"{where}.axis.direction")
        ang = math.fmod(number(e.get("angle_deg"), f"{where}.angle_deg", -ANGLE_MAX, ANGLE_MAX), 360.0)
        expect(ang != 0.0, f"{where}.angle_deg must not be a multiple of 360", field=f"{where}.angle_deg")
        faces = e.get("faces")
        expect(isinstance(faces, list) and len(faces) == 2 and all(isinstance(f, str) and f in selections
                                                                    for f in faces),
               f"{where}.faces must name two selections; defined: {sorted(selections)}", field=f"{where}.faces")
        tol = number(e["tolerance"], f"{where}.tolerance", 0.0, MAX_COORDINATE) if "tolerance" in e else None
        cyc.append(CyclicEntry(_name(e, where), tuple(c.tolist()), tuple(t.tolist()), ang,  # type: ignore
                               (faces[0], faces[1]), tol))
    _names(cyc, "cyclic")
    tgs = []
    for k, e in enumerate(_list(doc, "targets")):
        where = f"SPEC.targets[{k}]"
        check_keys(e, ("name", "selection", "surface", "method", "tolerance"), where)
        expect(isinstance(e.get("selection"), str) and e.get("selection") in selections,
               f"{where}.selection: unknown selection {e.get('selection')!r}; defined: {sorted(selections)}",
               field=where)
        surf = e.get("surface")
        if isinstance(surf, dict):
            check_keys(surf, ("vertices", "triangles", "mesh_id"), f"{where}.surface")
            expect("mesh_id" not in surf, f"{where}.surface: a stored surface (mesh_id) is resolved by the "
                   "service; the library takes a file path or vertices and triangles", field=f"{where}.surface")
            expect(isinstance(surf.get("vertices"), list) and isinstance(surf.get("triangles"), list),
                   f"{where}.surface needs vertices and triangles", field=f"{where}.surface")
        else:
            expect(isinstance(surf, str) and surf != "", f"{where}.surface must be a file path or "
                   "{\"vertices\", \"triangles\"}", field=f"{where}.surface")
        method = e.get("method", "closest")
        expect(method in ("closest", "normal"), f"{where}.method must be 'closest' or 'normal'", field=where)
        tol = number(e["tolerance"], f"{where}.tolerance", 0.0, MAX_COORDINATE) if "tolerance" in e else None
        tgs.append(TargetEntry(_name(e, where), e["selection"], surf, method, tol))
    _names(tgs, "targets")
    return {"points": tuple(pts), "relative": tuple(rel), "features": tuple(feats), "motion": tuple(mot),
            "sliding": tuple(sl), "symmetry": tuple(sym), "cyclic": tuple(cyc), "targets": tuple(tgs)}


def _list(doc: dict[str, Any], key: str) -> list[Any]:
    val = doc.get(key, [])
    expect(isinstance(val, list), f"SPEC.{key} must be a list", field=key)
    return val
