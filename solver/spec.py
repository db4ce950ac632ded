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

from .errors import SpecError

__all__ = ["Spec", "HandleMove", "Move", "parse_spec", "parse_move", "axis_angle_matrix",
           "SOLVE_MODES", "METHODS", "LAPLACIANS", "ROTATIONS", "INVERSION_POLICIES"]

LAPLACIANS = ("cotangent", "uniform")
METHODS = ("null_space", "penalty")
SOLVE_MODES = ("auto", "split", "joint")
ROTATIONS = ("harmonic", "least_squares")
INVERSION_POLICIES = ("warn", "reject")
SELECTION_KINDS = ("ids", "set", "box", "sphere", "plane")


@dataclass(frozen=True)
class Spec:
    """A parsed SPEC.

    Attributes
    ----------
    selections : dict of str to dict
        Named selections (see :mod:`solver.selection`).
    fixed : tuple of str
        Selections that keep their rest positions.
    handles : dict of str to str
        Handle name to selection name.
    laplacian : {"cotangent", "uniform"}
        Weights of the boundary rows (eq. 3.1, or eq. 9 of the ECLS paper).
    method : {"null_space", "penalty"}
        Hard constraints by elimination (exact), or the paper's penalty weight.
    penalty_weight : float
        ``beta`` of eq. (3.8) and (4.2) when ``method == "penalty"``.
    solve : {"auto", "split", "joint"}
        Position solve; ``auto`` picks the split solve where it is exact.
    rotation : {"harmonic", "least_squares"}
        Rotation propagation: harmonic interpolation of quaternion logarithms
        (ECLS eq. 25-27) or the least-squares form of eq. (3.8)/(3.9).
    inversion : {"warn", "reject"}
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

    def to_dict(self) -> dict[str, Any]:
        """Return the SPEC as a JSON-compatible dict."""
        return {
            "selections": self.selections, "fixed": list(self.fixed), "handles": dict(self.handles),
            "laplacian": self.laplacian,
            "constraints": {"method": self.method, "penalty_weight": self.penalty_weight},
            "solve": self.solve, "rotation": self.rotation, "inversion": self.inversion,
        }


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
        "rotation": ..., "inversion": ...}``.

    Returns
    -------
    Spec

    Raises
    ------
    SpecError
        Unknown fields, names that are not selections, bad values, a selection
        used both as fixed and as a handle, or two handles on one selection.

    Examples
    --------
    >>> s = parse_spec({"selections": {"a": {"ids": [0]}, "b": {"ids": [1]}},
    ...                 "fixed": ["a"], "handles": {"h": "b"}})
    >>> s.handles, s.method
    ({'h': 'b'}, 'null_space')
    """
    _check_keys(doc, ("selections", "fixed", "handles", "laplacian", "constraints", "solve",
                      "rotation", "inversion"), "SPEC")
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
                                  ("inversion", INVERSION_POLICIES, "warn")):
        val = doc.get(key, default)
        _expect(val in allowed, f"SPEC.{key} must be one of {list(allowed)}, got {val!r}", field=key)
        out[key] = val
    _expect(not (method == "penalty" and out["solve"] == "split"),
            "SPEC.solve 'split' needs hard constraints (constraints.method 'null_space')", field="solve")
    return Spec(selections=selections, fixed=tuple(fixed), handles={str(k): v for k, v in handles.items()},
                method=method, penalty_weight=beta, **out)


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
    """A parsed MOVE: one :class:`HandleMove` per named handle (missing ones stay at rest)."""

    handles: dict[str, HandleMove]

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
        return {"handles": out}


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


def parse_move(doc: Any, handle_names: tuple[str, ...] | list[str]) -> Move:
    """Parse and validate a MOVE document against the SPEC's handle names.

    Parameters
    ----------
    doc : dict
        ``{"handles": {HANDLE: {"translation": [..], "rotation": {...}, "pivot": [..],
        "scale": s}}}``; every field is optional.
    handle_names : sequence of str

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
    _check_keys(doc, ("handles",), "MOVE")
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
    return Move(out)
