"""The SPEC and MOVE documents: parsing, validation and handle transforms.

SPEC (what is fixed, what moves, how to solve) and MOVE (where the handles go)
are plain JSON-compatible dicts; they are the public contract shared by the
library, the CLI and the REST service. Parsing is strict: unknown fields,
unknown names and malformed values raise :class:`SpecError` before any work.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import SpecError

__all__ = ["Spec", "HandleMove", "Move", "parse_spec", "parse_move", "axis_angle_matrix",
           "SOLVE_MODES", "METHODS", "LAPLACIANS", "ROTATIONS", "INVERSION_POLICIES",
           "CONFLICT_POLICIES", "FEATURE_MODES", "RELATIVE_MODES"]

LAPLACIANS = ("cotangent", "uniform")
METHODS = ("null_space", "kkt", "penalty")
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
SELECTION_KINDS = ("ids", "set", "box", "sphere", "plane")


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
        back to its safe fraction (see :meth:`solver.deform.deformer.Deformer.safe_fraction`).
    points, relative, features, motion, sliding : tuple of dict
        The further hard constraints, normalised (see :func:`parse_spec`).
    conflicts : {"report", "reject"}
        What a conflicting constraint does: reported in the REPORT, or the
        SPEC (and any MOVE) that makes constraints conflict is refused.
    repair : bool
        Untangle inverted elements after each solve by moving free interior
        vertices near them (:mod:`solver.validity.repair`).
    ties : "auto", False, {"tolerance": t} or list of [i, j]
        Hard ties ``p_i = p_j`` (and equal rotations) between coincident nodes of
        different bodies (assemblies); ``"auto"`` finds them within 1e-9 of the
        diagonal.
    voids : {"volume", "refuse"}
        An internal void (a boundary shell with no fixed or handle vertex):
        positioned by the surrounding volume (its rotation field extended
        harmonically through the tets, its translation by the mean-value rows
        of the interior around it; joint solve), or refused.
    thin_walls : float
        Weight of the rows that tie the two faces of walls one tet thick
        (default ``THIN_WALL_WEIGHT``; 0 is the paper's method unchanged). See
        :meth:`solver.deform.deformer.Deformer._wall_rows` and the README.
    """

    selections: dict[str, dict[str, Any]]
    fixed: tuple[str, ...] = ()
    handles: dict[str, str] = field(default_factory=dict)
    laplacian: str = "cotangent"
    method: str = "null_space"
    penalty_weight: float = 1.0e4
    solve: str = "auto"
    rotation: str = "harmonic"
    inversion: str = "warn"
    points: tuple[dict[str, Any], ...] = ()
    relative: tuple[dict[str, Any], ...] = ()
    features: tuple[dict[str, Any], ...] = ()
    motion: tuple[dict[str, Any], ...] = ()
    sliding: tuple[dict[str, Any], ...] = ()
    conflicts: str = "report"
    repair: bool = False
    thin_walls: float = 0.1
    ties: Any = "auto"
    voids: str = "volume"

    def to_dict(self) -> dict[str, Any]:
        """Return the SPEC as a JSON-compatible dict."""
        out = {
            "selections": self.selections, "fixed": list(self.fixed), "handles": dict(self.handles),
            "laplacian": self.laplacian,
            "constraints": {"method": self.method, "penalty_weight": self.penalty_weight},
            "solve": self.solve, "rotation": self.rotation, "inversion": self.inversion,
            "conflicts": self.conflicts, "repair": self.repair, "thin_walls": self.thin_walls,
            "ties": self.ties, "voids": self.voids,
        }
        for key in ("points", "relative", "features", "motion", "sliding"):
            if getattr(self, key):
                out[key] = [dict(e) for e in getattr(self, key)]
        return out


def _expect(cond: bool, msg: str, **details: Any) -> None:
    if not cond:
        raise SpecError(msg, **details)


def _vec3(x: Any, where: str) -> np.ndarray:
    try:
        v = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise SpecError(f"{where} must be 3 numbers, got {x!r}", field=where) from None
    _expect(v.shape == (3,), f"{where} must be 3 numbers, got {x!r}", field=where)
    _expect(bool(np.all(np.isfinite(v))), f"{where} must be finite, got {x!r}", field=where)
    return v


def _number(x: Any, where: str) -> float:
    _expect(isinstance(x, (int, float)) and not isinstance(x, bool),
            f"{where} must be a number, got {x!r}", field=where)
    _expect(math.isfinite(float(x)), f"{where} must be finite, got {x!r}", field=where)
    return float(x)


def _check_keys(d: Any, allowed: tuple[str, ...], where: str) -> None:
    _expect(isinstance(d, dict), f"{where} must be an object, got {type(d).__name__}", field=where)
    unknown = sorted(set(d) - set(allowed))
    _expect(not unknown, f"unknown field(s) {unknown} in {where}; allowed: {list(allowed)}",
            field=where, unknown=unknown)


def _check_selection(name: str, sel: Any) -> dict[str, Any]:
    where = f"selections.{name}"
    _check_keys(sel, (*SELECTION_KINDS, "boundary_only"), where)
    kinds = [k for k in sel if k in SELECTION_KINDS]
    _expect(len(kinds) == 1, f"{where} must have exactly one of {list(SELECTION_KINDS)}", field=where)
    _expect(isinstance(sel.get("boundary_only", False), bool),
            f"{where}.boundary_only must be true or false", field=where)
    kind = kinds[0]
    val = sel[kind]
    if kind == "ids":
        _expect(isinstance(val, list) and all(isinstance(i, int) and not isinstance(i, bool)
                                              for i in val),
                f"{where}.ids must be a list of integers", field=where)
    elif kind == "set":
        _expect(isinstance(val, str), f"{where}.set must be a set name", field=where)
    elif kind == "box":
        _check_keys(val, ("min", "max"), f"{where}.box")
        lo = _vec3(val.get("min"), f"{where}.box.min")
        hi = _vec3(val.get("max"), f"{where}.box.max")
        _expect(bool(np.all(lo <= hi)), f"{where}.box: min {lo.tolist()} exceeds max {hi.tolist()}",
                field=where)
    elif kind == "sphere":
        _check_keys(val, ("center", "radius"), f"{where}.sphere")
        _vec3(val.get("center"), f"{where}.sphere.center")
        _expect(_number(val.get("radius"), f"{where}.sphere.radius") >= 0,
                f"{where}.sphere.radius must be >= 0", field=where)
    elif kind == "plane":
        _check_keys(val, ("point", "normal", "tolerance"), f"{where}.plane")
        _vec3(val.get("point"), f"{where}.plane.point")
        nrm = _vec3(val.get("normal"), f"{where}.plane.normal")
        _expect(float(np.linalg.norm(nrm)) > 0, f"{where}.plane.normal must be non-zero", field=where)
        _expect(_number(val.get("tolerance", 0.0), f"{where}.plane.tolerance") >= 0,
                f"{where}.plane.tolerance must be >= 0", field=where)
    return sel


def parse_spec(doc: Any) -> Spec:
    """Parse and validate a SPEC document.

    Parameters
    ----------
    doc : dict
        ``{"selections": {...}, "fixed": [...], "handles": {...}, "laplacian": ...,
        "constraints": {"method": ..., "penalty_weight": ...}, "solve": ...,
        "rotation": ..., "inversion": ..., "points": [...], "relative": [...],
        "features": [...], "motion": [...], "sliding": [...], "conflicts": ...}``;
        the README's "Hard constraints" section gives each form.

    Returns
    -------
    Spec

    Raises
    ------
    SpecError
        Unknown fields, names that are not selections, bad values, a selection
        used both as fixed and as a handle, two handles on one selection, or a
        constraint name used twice in one list.

    Examples
    --------
    >>> s = parse_spec({"selections": {"a": {"ids": [0]}, "b": {"ids": [1]}},
    ...                 "fixed": ["a"], "handles": {"h": "b"}})
    >>> s.handles, s.method
    ({'h': 'b'}, 'null_space')
    """
    _check_keys(doc, ("selections", "fixed", "handles", "laplacian", "constraints", "solve",
                      "rotation", "inversion", "points", "relative", "features", "motion", "sliding",
                      "conflicts", "repair", "thin_walls", "ties", "voids"), "SPEC")
    sels = doc.get("selections", {})
    _expect(isinstance(sels, dict) and len(sels) > 0, "SPEC.selections must name at least one selection",
            field="selections")
    selections = {str(k): _check_selection(str(k), v) for k, v in sels.items()}
    fixed = doc.get("fixed", [])
    _expect(isinstance(fixed, list) and all(isinstance(f, str) for f in fixed),
            "SPEC.fixed must be a list of selection names", field="fixed")
    handles = doc.get("handles", {})
    _expect(isinstance(handles, dict) and all(isinstance(v, str) for v in handles.values()),
            "SPEC.handles must map handle names to selection names", field="handles")
    for name in [*fixed, *handles.values()]:
        _expect(name in selections, f"unknown selection {name!r}; defined: {sorted(selections)}",
                field="selections", name=name)
    both = sorted(set(fixed) & set(handles.values()))
    _expect(not both, f"selection(s) {both} are both fixed and a handle", field="handles", names=both)
    used = list(handles.values())
    dup = sorted({s for s in used if used.count(s) > 1})
    _expect(not dup, f"selection(s) {dup} drive more than one handle", field="handles", names=dup)
    _expect(len(fixed) + len(handles) > 0, "SPEC needs at least one fixed selection or handle",
            field="fixed")
    extra = _parse_constraint_lists(doc, selections)
    cons = doc.get("constraints", {})
    _check_keys(cons, ("method", "penalty_weight"), "SPEC.constraints")
    method = cons.get("method", "null_space")
    _expect(method in METHODS, f"SPEC.constraints.method must be one of {list(METHODS)}, got {method!r}",
            field="constraints.method")
    beta = _number(cons.get("penalty_weight", 1.0e4), "SPEC.constraints.penalty_weight")
    _expect(beta > 0, "SPEC.constraints.penalty_weight must be > 0", field="constraints.penalty_weight")
    out = {}
    for key, allowed, default in (("laplacian", LAPLACIANS, "cotangent"), ("solve", SOLVE_MODES, "auto"),
                                  ("rotation", ROTATIONS, "harmonic"),
                                  ("inversion", INVERSION_POLICIES, "warn"),
                                  ("conflicts", CONFLICT_POLICIES, "report"),
                                  ("voids", ("volume", "refuse"), "volume")):
        val = doc.get(key, default)
        _expect(val in allowed, f"SPEC.{key} must be one of {list(allowed)}, got {val!r}", field=key)
        out[key] = val
    repair = doc.get("repair", False)
    _expect(isinstance(repair, bool), f"SPEC.repair must be true or false, got {repair!r}", field="repair")
    out["repair"] = repair
    tw = doc.get("thin_walls", True)
    if isinstance(tw, bool):
        tw = THIN_WALL_WEIGHT if tw else 0.0
    else:
        _expect(isinstance(tw, dict) and set(tw) <= {"weight"}, "SPEC.thin_walls must be true, false or "
                "{\"weight\": w}", field="thin_walls")
        tw = _number(tw.get("weight", 1.0), "SPEC.thin_walls.weight")
        _expect(tw >= 0, "SPEC.thin_walls.weight must be >= 0", field="thin_walls")
    out["thin_walls"] = float(tw)
    ties = doc.get("ties", "auto")
    if isinstance(ties, dict):
        _check_keys(ties, ("tolerance",), "SPEC.ties")
        _expect(_number(ties.get("tolerance"), "SPEC.ties.tolerance") >= 0, "SPEC.ties.tolerance must be >= 0",
                field="ties")
    elif isinstance(ties, list):
        for k, pair in enumerate(ties):
            _int_list(pair, f"SPEC.ties[{k}]", 2)
    else:
        _expect(ties in ("auto", False), "SPEC.ties must be \"auto\", false, {\"tolerance\": t} or a list "
                "of [i, j] vertex pairs", field="ties")
    out["ties"] = ties
    _expect(not (method == "penalty" and out["solve"] == "split"),
            "SPEC.solve 'split' needs exact constraints (constraints.method 'null_space' or 'kkt')",
            field="solve")
    return Spec(selections=selections, fixed=tuple(fixed), handles={str(k): v for k, v in handles.items()},
                method=method, penalty_weight=beta, **out, **extra)


def _int_list(x: Any, where: str, length: int | None = None) -> list[int]:
    ok = isinstance(x, list) and all(isinstance(i, int) and not isinstance(i, bool) for i in x) \
        and len(x) > 0
    _expect(ok, f"{where} must be a non-empty list of vertex indices, got {x!r}", field=where)
    if length is not None:
        _expect(len(x) == length, f"{where} must have {length} vertex indices, got {len(x)}", field=where)
    _expect(len(set(x)) == len(x), f"{where} repeats a vertex: {x!r}", field=where)
    return list(x)


def _point_def(e: dict[str, Any], where: str, selections: dict[str, Any]) -> dict[str, Any]:
    """A point as a linear combination of vertices: ``{"vertices", "weights"}`` or a selection."""
    forms = [k for k in ("vertices", "edge", "face", "selection") if k in e]
    _expect(len(forms) == 1, f"{where} must give exactly one of vertices+weights, edge+t, "
            "face+barycentric or selection", field=where)
    form = forms[0]
    if form == "selection":
        _expect(e["selection"] in selections, f"{where}.selection: unknown selection {e['selection']!r}; "
                f"defined: {sorted(selections)}", field=where)
        _expect("weights" not in e, f"{where}: a selection point is its centroid; no weights", field=where)
        return {"selection": e["selection"]}
    if form == "edge":
        ids = _int_list(e["edge"], f"{where}.edge", 2)
        t = _number(e.get("t"), f"{where}.t")
        _expect(0.0 <= t <= 1.0, f"{where}.t must be in [0, 1], got {t}", field=where)
        return {"vertices": ids, "weights": [t, 1.0 - t]}
    if form == "face":
        ids = _int_list(e["face"], f"{where}.face", 3)
        w = e.get("barycentric")
        _expect(isinstance(w, list) and len(w) == 3, f"{where}.barycentric must be 3 numbers", field=where)
        w = [_number(x, f"{where}.barycentric") for x in w]
        _expect(abs(sum(w) - 1.0) <= 1e-9 and min(w) >= 0, f"{where}.barycentric must be >= 0 and sum "
                f"to 1, got {w}", field=where)
        return {"vertices": ids, "weights": w}
    ids = _int_list(e["vertices"], f"{where}.vertices")
    w = e.get("weights", [1.0 / len(ids)] * len(ids))
    _expect(isinstance(w, list) and len(w) == len(ids), f"{where}.weights must be {len(ids)} numbers "
            "(one per vertex)", field=where)
    w = [_number(x, f"{where}.weights") for x in w]
    _expect(abs(sum(w)) > 1e-12, f"{where}.weights must not sum to zero", field=where)
    return {"vertices": ids, "weights": w}


def _names(entries: list[dict[str, Any]], key: str) -> None:
    names = [e["name"] for e in entries]
    dup = sorted({n for n in names if names.count(n) > 1})
    _expect(not dup, f"SPEC.{key}: name(s) {dup} used twice", field=key, names=dup)


def _parse_constraint_lists(doc: dict[str, Any], selections: dict[str, Any]) -> dict[str, Any]:
    """Parse SPEC ``points``, ``relative``, ``features``, ``motion`` and ``sliding``."""
    out: dict[str, Any] = {}
    lists = {}
    for key in ("points", "relative", "features", "motion", "sliding"):
        val = doc.get(key, [])
        _expect(isinstance(val, list), f"SPEC.{key} must be a list", field=key)
        lists[key] = val
    pts = []
    for k, e in enumerate(lists["points"]):
        where = f"SPEC.points[{k}]"
        _check_keys(e, ("name", "vertices", "weights", "edge", "t", "face", "barycentric", "selection",
                        "target"), where)
        _expect(isinstance(e.get("name"), str), f"{where}.name must be a string", field=where)
        p = {"name": e["name"], **_point_def(e, where, selections)}
        if "target" in e:
            p["target"] = _vec3(e["target"], f"{where}.target").tolist()
        pts.append(p)
    _names(pts, "points")
    rel = []
    for k, e in enumerate(lists["relative"]):
        where = f"SPEC.relative[{k}]"
        _check_keys(e, ("name", "vertices", "mode"), where)
        _expect(isinstance(e.get("name"), str), f"{where}.name must be a string", field=where)
        mode = e.get("mode", "rotate")
        _expect(mode in RELATIVE_MODES, f"{where}.mode must be one of {list(RELATIVE_MODES)}", field=where)
        rel.append({"name": e["name"], "vertices": _int_list(e.get("vertices"), f"{where}.vertices", 2),
                    "mode": mode})
    _names(rel, "relative")
    feats = []
    for k, e in enumerate(lists["features"]):
        where = f"SPEC.features[{k}]"
        _check_keys(e, ("name", "selection", "mode"), where)
        _expect(e.get("selection") in selections, f"{where}.selection: unknown selection "
                f"{e.get('selection')!r}; defined: {sorted(selections)}", field=where)
        mode = e.get("mode", "rigid")
        _expect(mode in FEATURE_MODES, f"{where}.mode must be one of {list(FEATURE_MODES)}", field=where)
        name = e.get("name", e["selection"])
        _expect(isinstance(name, str), f"{where}.name must be a string", field=where)
        feats.append({"name": name, "selection": e["selection"], "mode": mode})
    _names(feats, "features")
    mot = []
    for k, e in enumerate(lists["motion"]):
        where = f"SPEC.motion[{k}]"
        _check_keys(e, ("name", "vertices", "weights", "edge", "t", "face", "barycentric", "selection",
                        "plane", "line"), where)
        _expect(isinstance(e.get("name"), str), f"{where}.name must be a string", field=where)
        m = {"name": e["name"], **_point_def(e, where, selections)}
        _expect(("plane" in e) != ("line" in e), f"{where} needs exactly one of plane or line", field=where)
        if "plane" in e:
            _check_keys(e["plane"], ("normal",), f"{where}.plane")
            nrm = _vec3(e["plane"].get("normal"), f"{where}.plane.normal")
            _expect(float(np.linalg.norm(nrm)) > 0, f"{where}.plane.normal must be non-zero", field=where)
            m["plane"] = {"normal": nrm.tolist()}
        else:
            _check_keys(e["line"], ("direction",), f"{where}.line")
            t = _vec3(e["line"].get("direction"), f"{where}.line.direction")
            _expect(float(np.linalg.norm(t)) > 0, f"{where}.line.direction must be non-zero", field=where)
            m["line"] = {"direction": t.tolist()}
        mot.append(m)
    _names(mot, "motion")
    sl = []
    for k, e in enumerate(lists["sliding"]):
        where = f"SPEC.sliding[{k}]"
        _check_keys(e, ("selection", "normal"), where)
        _expect(e.get("selection") in selections, f"{where}.selection: unknown selection "
                f"{e.get('selection')!r}; defined: {sorted(selections)}", field=where)
        nrm = _vec3(e.get("normal"), f"{where}.normal")
        _expect(float(np.linalg.norm(nrm)) > 0, f"{where}.normal must be non-zero", field=where)
        sl.append({"selection": e["selection"], "normal": nrm.tolist()})
    out.update(points=tuple(pts), relative=tuple(rel), features=tuple(feats), motion=tuple(mot),
               sliding=tuple(sl))
    return out


def axis_angle_matrix(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix about a unit ``axis`` by ``angle`` radians (Rodrigues).

    Parameters
    ----------
    axis : (3,) float array
        Unit vector.
    angle : float

    Returns
    -------
    R : (3, 3) float array

    Examples
    --------
    >>> np.round(axis_angle_matrix(np.array([0., 0, 1]), np.pi / 2) @ [1, 0, 0], 12).tolist()
    [0.0, 1.0, 0.0]
    """
    x, y, z = axis
    K = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * (K @ K)


@dataclass(frozen=True)
class HandleMove:
    """Rigid motion with uniform scale of one handle: ``u = pivot + t + s R (p0 - pivot)``.

    Attributes
    ----------
    translation : (3,) float array
    log_rotation : (3,) float array
        Quaternion logarithm ``(theta / 2) * axis`` (eq. 24 of the ECLS paper).
    scale : float
    pivot : (3,) float array or None
        ``None`` means the handle's rest centroid.
    """

    translation: np.ndarray
    log_rotation: np.ndarray
    scale: float = 1.0
    pivot: np.ndarray | None = None

    @property
    def matrix(self) -> np.ndarray:
        """(3, 3) rotation matrix."""
        r = self.log_rotation
        th = 2.0 * float(np.linalg.norm(r))
        if th == 0.0:
            return np.eye(3)
        return axis_angle_matrix(r / np.linalg.norm(r) , th)

    def apply(self, P0: np.ndarray, centroid: np.ndarray) -> np.ndarray:
        """Targets of rest positions ``P0`` (k, 3) under this move."""
        c = centroid if self.pivot is None else self.pivot
        return c + self.translation + self.scale * (P0 - c) @ self.matrix.T

    def interpolate(self, f: float) -> HandleMove:
        """The move scaled by ``f``: translation f, angle f, scale**f."""
        return HandleMove(self.translation * f, self.log_rotation * f, self.scale ** f, self.pivot)


@dataclass(frozen=True)
class Move:
    """A parsed MOVE: one :class:`HandleMove` per named handle (missing ones stay at rest).

    Attributes
    ----------
    handles : dict of str to HandleMove
    points : dict of str to (3,) array
        Targets of SPEC ``points`` (missing: the SPEC's target, else rest).
    relative : dict of str to dict
        ``{"offset": (3,) array}`` or ``{"scale": s}`` per SPEC ``relative``.
    features : dict of str to float
        Scale factor ``s_f`` per SPEC ``features`` (missing: 1).
    motion : dict of str to (3,) array
        The point the plane or line of a SPEC ``motion`` passes through.
    """

    handles: dict[str, HandleMove]
    points: dict[str, np.ndarray] = field(default_factory=dict)
    relative: dict[str, dict[str, Any]] = field(default_factory=dict)
    features: dict[str, float] = field(default_factory=dict)
    motion: dict[str, np.ndarray] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """Return the MOVE as a JSON-compatible dict (rotations as quaternions)."""
        out = {}
        for k, h in self.handles.items():
            th = 2 * float(np.linalg.norm(h.log_rotation))
            axis = h.log_rotation / (th / 2) if th else np.array([0.0, 0.0, 1.0])
            d: dict[str, Any] = {"translation": h.translation.tolist(),
                                 "rotation": {"axis": axis.tolist(), "angle_deg": math.degrees(th)},
                                 "scale": h.scale}
            if h.pivot is not None:
                d["pivot"] = h.pivot.tolist()
            out[k] = d
        doc: dict[str, Any] = {"handles": out}
        if self.points:
            doc["points"] = {k: v.tolist() for k, v in self.points.items()}
        if self.relative:
            doc["relative"] = {k: {a: (b.tolist() if isinstance(b, np.ndarray) else b)
                                   for a, b in v.items()} for k, v in self.relative.items()}
        if self.features:
            doc["features"] = {k: {"scale": v} for k, v in self.features.items()}
        if self.motion:
            doc["motion"] = {k: {"point": v.tolist()} for k, v in self.motion.items()}
        return doc


def _parse_rotation(rot: Any, where: str) -> np.ndarray:
    _check_keys(rot, ("axis", "angle_deg", "quaternion"), where)
    if "quaternion" in rot:
        _expect("axis" not in rot and "angle_deg" not in rot,
                f"{where}: give either axis+angle_deg or quaternion, not both", field=where)
        try:
            q = np.asarray(rot["quaternion"], dtype=np.float64)
        except (TypeError, ValueError):
            raise SpecError(f"{where}.quaternion must be 4 numbers [w, x, y, z]", field=where) from None
        _expect(q.shape == (4,) and bool(np.all(np.isfinite(q))),
                f"{where}.quaternion must be 4 finite numbers [w, x, y, z]", field=where)
        nq = float(np.linalg.norm(q))
        _expect(nq > 0, f"{where}.quaternion must be non-zero", field=where)
        q = q / nq
        if q[0] < 0:
            q = -q  # the shorter of the two equal rotations
        v = q[1:]
        nv = float(np.linalg.norm(v))
        if nv == 0:
            return np.zeros(3)
        return math.atan2(nv, q[0]) * v / nv
    _expect("axis" in rot and "angle_deg" in rot, f"{where} needs axis and angle_deg (or quaternion)",
            field=where)
    axis = _vec3(rot["axis"], f"{where}.axis")
    angle = math.radians(_number(rot["angle_deg"], f"{where}.angle_deg"))
    na = float(np.linalg.norm(axis))
    if angle == 0.0:
        return np.zeros(3)
    _expect(na > 0, f"{where}.axis must be non-zero", field=where)
    return (angle / 2.0) * axis / na


def parse_move(doc: Any, handle_names: tuple[str, ...] | list[str],
               names: dict[str, Any] | None = None) -> Move:
    """Parse and validate a MOVE document against the SPEC's names.

    Parameters
    ----------
    doc : dict
        ``{"handles": {HANDLE: {"translation": [..], "rotation": {...}, "pivot": [..],
        "scale": s}}, "points": {POINT: [x, y, z]}, "relative": {NAME: {"offset": [..]}
        | {"scale": s}}, "features": {FEATURE: {"scale": s}}, "motion": {NAME:
        {"point": [x, y, z]}}}``; every field is optional.
    handle_names : sequence of str
    names : dict, optional
        Names the SPEC defines per category (``"points"``, ``"relative"``,
        ``"features"``, ``"motion"``); categories not given accept no names.

    Returns
    -------
    Move

    Raises
    ------
    SpecError

    Examples
    --------
    >>> m = parse_move({"handles": {"h": {"translation": [1, 0, 0]}}}, ["h"])
    >>> m.handles["h"].translation.tolist()
    [1.0, 0.0, 0.0]
    """
    _check_keys(doc, ("handles", "points", "relative", "features", "motion"), "MOVE")
    names = names or {}
    for key in ("points", "relative", "features", "motion"):
        val = doc.get(key, {})
        _expect(isinstance(val, dict), f"MOVE.{key} must be an object", field=key)
        bad = sorted(set(val) - set(names.get(key, ())))
        _expect(not bad, f"MOVE.{key} names unknown {key} {bad}; the SPEC defines "
                f"{sorted(names.get(key, ()))}", field=key, unknown=bad)
    hs = doc.get("handles", {})
    _expect(isinstance(hs, dict), "MOVE.handles must be an object", field="handles")
    unknown = sorted(set(hs) - set(handle_names))
    _expect(not unknown, f"MOVE names unknown handle(s) {unknown}; the SPEC defines {sorted(handle_names)}",
            field="handles", unknown=unknown)
    out = {}
    for name, h in hs.items():
        where = f"MOVE.handles.{name}"
        _check_keys(h, ("translation", "rotation", "pivot", "scale"), where)
        t = _vec3(h["translation"], f"{where}.translation") if "translation" in h else np.zeros(3)
        r = _parse_rotation(h["rotation"], f"{where}.rotation") if "rotation" in h else np.zeros(3)
        s = _number(h.get("scale", 1.0), f"{where}.scale")
        _expect(s > 0, f"{where}.scale must be > 0, got {s}", field=f"{where}.scale")
        p = _vec3(h["pivot"], f"{where}.pivot") if "pivot" in h else None
        out[name] = HandleMove(t, r, s, p)
    points = {k: _vec3(v, f"MOVE.points.{k}") for k, v in doc.get("points", {}).items()}
    relative = {}
    for k, v in doc.get("relative", {}).items():
        where = f"MOVE.relative.{k}"
        _check_keys(v, ("offset", "scale"), where)
        _expect(len(v) == 1, f"{where} needs exactly one of offset or scale", field=where)
        if "offset" in v:
            relative[k] = {"offset": _vec3(v["offset"], f"{where}.offset")}
        else:
            sc = _number(v["scale"], f"{where}.scale")
            _expect(sc > 0, f"{where}.scale must be > 0, got {sc}", field=where)
            relative[k] = {"scale": sc}
    features = {}
    for k, v in doc.get("features", {}).items():
        where = f"MOVE.features.{k}"
        _check_keys(v, ("scale",), where)
        sc = _number(v.get("scale", 1.0), f"{where}.scale")
        _expect(sc > 0, f"{where}.scale must be > 0, got {sc}", field=where)
        features[k] = sc
    motion = {}
    for k, v in doc.get("motion", {}).items():
        where = f"MOVE.motion.{k}"
        _check_keys(v, ("point",), where)
        motion[k] = _vec3(v.get("point"), f"{where}.point")
    return Move(out, points, relative, features, motion)
