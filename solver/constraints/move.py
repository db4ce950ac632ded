"""A MOVE as the solver uses it: where the handles go, and the targets of the other constraints.

:func:`parse_move` validates the document with its one model
(:class:`solver.documents.move.Move`: JSON numbers only, not booleans or strings,
finite and in range), then against the SPEC's names and the mesh's extent.
Angles are reduced modulo 360 degrees (keeping their sign, so a 350 degree
twist stays a twist, not a -10 degree turn); scales lie in ``SCALE_RANGE``;
translations, pivots and targets lie within ``MOVE_RANGE`` mesh diagonals of
the mesh when the caller gives the mesh's extent (:class:`MoveBounds`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..limits import EXTENT, SCALE_MAX, SCALE_MIN
from .edit_kinds import EDIT_KINDS
from .spec import expect

if TYPE_CHECKING:
    from ..documents.move import Rotation as RotationDoc
    from .edit_values import EditValue

__all__ = ["HandleMove", "ResolvedMove", "MoveBounds", "RestTargets", "parse_move", "scaled_move", "axis_angle_matrix",
           "SCALE_RANGE", "MOVE_RANGE"]

#: Scales (handles, features, relative constraints) must lie in this range.
SCALE_RANGE = (SCALE_MIN, SCALE_MAX)
#: Translations, pivots and targets must lie within this many mesh diagonals of the mesh.
MOVE_RANGE = EXTENT


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
        ``None`` means the handle's rest centroid (over all its nodes, mid-side nodes included).
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
        return axis_angle_matrix(r / np.linalg.norm(r), th)

    def apply(self, P0: np.ndarray, centroid: np.ndarray) -> np.ndarray:
        """Targets of rest positions ``P0`` (k, 3) under this move.

        Summed as ``P0 + t + (P0 - pivot) (s R - I)^T``, so that the identity
        (zero translation and angle, unit scale) returns ``P0`` bit for bit.
        """
        c = centroid if self.pivot is None else self.pivot
        return P0 + (self.translation + (P0 - c) @ (self.scale * self.matrix - np.eye(3)).T)

    def interpolate(self, f: float) -> HandleMove:
        """The move scaled by ``f``: translation f, angle f, scale**f."""
        return HandleMove(self.translation * f, self.log_rotation * f, self.scale ** f, self.pivot)


@dataclass(frozen=True)
class ResolvedMove:
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
    targets : dict of str to float
        Amount per SPEC ``targets``: 0 rest, 1 on the target surface (missing: 0).
    edits : dict of str to dict of str to value
        Per edit kind (``radius``, ``twist``, ``map``, ``offset``, ``lattice``), the value of each
        named edit (:mod:`solver.constraints.edit_values`); an edit not named stays at rest.
    """

    handles: dict[str, HandleMove]
    points: dict[str, np.ndarray] = field(default_factory=dict)
    relative: dict[str, dict[str, Any]] = field(default_factory=dict)
    features: dict[str, float] = field(default_factory=dict)
    motion: dict[str, np.ndarray] = field(default_factory=dict)
    targets: dict[str, float] = field(default_factory=dict)
    edits: dict[str, dict[str, EditValue]] = field(default_factory=dict)

    def edit(self, kind: str, name: str) -> EditValue | None:
        """The value of one edit (None: at rest)."""
        return self.edits.get(kind, {}).get(name)

    def to_dict(self) -> dict[str, Any]:
        """Return the MOVE as a JSON-compatible dict (rotations as axis and angle)."""
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
            doc["relative"] = {k: {a: (b.tolist() if isinstance(b, np.ndarray) else b) for a, b in v.items()}
                               for k, v in self.relative.items()}
        if self.features:
            doc["features"] = {k: {"scale": v} for k, v in self.features.items()}
        if self.motion:
            doc["motion"] = {k: {"point": v.tolist()} for k, v in self.motion.items()}
        if self.targets:
            doc["targets"] = {k: {"amount": v} for k, v in self.targets.items()}
        if any(self.edits.values()):
            from .edit_values import value_dict

            doc.update(value_dict(self.edits))
        return doc


@dataclass(frozen=True)
class MoveBounds:
    """The mesh's extent, which bounds translations, pivots and targets.

    Attributes
    ----------
    center : (3,) float array
        Centre of the bounding box of the referenced vertices.
    diagonal : float
        Length of its diagonal.
    """

    center: np.ndarray
    diagonal: float

    @property
    def translation(self) -> float:
        """Largest translation or offset length, ``MOVE_RANGE`` diagonals."""
        return MOVE_RANGE * max(self.diagonal, 1e-300)

    def position(self, v: np.ndarray, where: str) -> np.ndarray:
        """``v`` checked to lie within ``MOVE_RANGE`` diagonals of the centre (else ``out_of_range``)."""
        d = float(np.linalg.norm(v - self.center))
        expect(d <= self.translation, f"{where}: distance from the mesh's centre {d:.3g} exceeds {MOVE_RANGE:g} "
               f"bounding-box diagonals of the mesh ({self.translation:.3g})", code="out_of_range", field=where,
               value=v.tolist(), bound=self.translation)
        return v

    def length(self, v: np.ndarray, where: str) -> np.ndarray:
        """``v`` checked to be at most ``MOVE_RANGE`` diagonals long (else ``out_of_range``)."""
        d = float(np.linalg.norm(v))
        expect(d <= self.translation, f"{where}: length {d:.3g} exceeds {MOVE_RANGE:g} bounding-box diagonals "
               f"of the mesh ({self.translation:.3g})", code="out_of_range", field=where, value=v.tolist(),
               bound=self.translation)
        return v


@dataclass(frozen=True)
class RestTargets:
    """Rest values of the MOVE-addressable targets, for :func:`scaled_move`.

    Attributes
    ----------
    points : dict of str to ((3,) array, (3,) array or None)
        Rest position and SPEC target of each SPEC point.
    motion : dict of str to (3,) array
        Rest position of each motion point.
    relative : dict of str to (3,) array
        Rest offset ``a - b`` of each relative constraint.
    nominal : dict of str to dict of str to float
        Per edit kind (``radius``, ``fillet``, ``distance``, ``angle``), each edit's nominal rest value:
        a bore's mean radius, a fillet's fitted radius, the rest distance, the rest angle in degrees.
    """

    points: dict[str, tuple[np.ndarray, np.ndarray | None]] = field(default_factory=dict)
    motion: dict[str, np.ndarray] = field(default_factory=dict)
    relative: dict[str, np.ndarray] = field(default_factory=dict)
    nominal: dict[str, dict[str, float]] = field(default_factory=dict)


def scaled_move(mv: ResolvedMove, f: float, rest: RestTargets) -> ResolvedMove:
    """The MOVE scaled by ``f`` in [0, 1]: ``f = 0`` is the rest shape, ``f = 1`` the MOVE.

    Handles: translation ``f t``, rotation angle ``f θ``, scale ``s^f``.
    Point and motion targets and relative offsets: ``rest + f (target - rest)``.
    Feature and relative scales: ``s^f``. Edits: :func:`~solver.constraints.edit_values.scaled_value`
    (a new radius ``r0 + f (r - r0)`` about the nominal rest radius ``r0``, a distance or an angle about
    its rest value; every other parameter times ``f``).
    """
    handles = {k: h.interpolate(f) for k, h in mv.handles.items()}
    points = {}
    for name, (r0, spec_target) in rest.points.items():
        target = mv.points.get(name, spec_target)
        if target is not None:
            points[name] = r0 + f * (np.asarray(target) - r0)
    motion = {k: rest.motion[k] + f * (v - rest.motion[k]) for k, v in mv.motion.items()}
    relative: dict[str, dict[str, Any]] = {}
    for k, v in mv.relative.items():
        if "offset" in v:
            r0 = rest.relative[k]
            relative[k] = {"offset": r0 + f * (v["offset"] - r0)}
        else:
            relative[k] = {"scale": v["scale"] ** f}
    features = {k: v ** f for k, v in mv.features.items()}
    targets = {k: f * v for k, v in mv.targets.items()}
    edits: dict[str, dict[str, EditValue]] = {kind: {} for kind in mv.edits}
    if any(mv.edits.values()):  # the edits' module loads for a MOVE that gives an edit a value
        from .edit_values import scaled_value

        edits = {kind: {n: scaled_value(v, f, rest.nominal.get(kind, {}).get(n)) for n, v in named.items()}
                 for kind, named in mv.edits.items()}
    return ResolvedMove(handles, points, relative, features, motion, targets, edits)


def _rotation_vector(rot: RotationDoc, where: str) -> np.ndarray:
    """The rotation's ``(angle / 2) * axis`` (the quaternion logarithm), from a validated rotation."""
    if rot.quaternion is not None:
        qa = np.asarray(rot.quaternion, float)
        nq = float(np.linalg.norm(qa))
        expect(nq > 1e-150, f"{where}.quaternion must be non-zero", field=f"{where}.quaternion")
        qa = qa / nq
        if qa[0] < 0:
            qa = -qa  # the shorter of the two equal rotations
        v = qa[1:]
        nv = float(np.linalg.norm(v))
        if nv == 0:
            return np.zeros(3)
        return math.atan2(nv, qa[0]) * v / nv
    assert rot.axis is not None and rot.angle_deg is not None  # the model requires both
    deg = math.fmod(rot.angle_deg, 360.0)  # exact, signed
    if deg == 0.0:
        return np.zeros(3)
    axis = np.asarray(rot.axis, float)
    na = float(np.linalg.norm(axis))
    expect(na > 1e-150, f"{where}.axis must be non-zero", field=f"{where}.axis")
    return (math.radians(deg) / 2.0) * axis / na


def parse_move(doc: Any, handle_names: tuple[str, ...] | list[str], names: dict[str, Any] | None = None,
               bounds: MoveBounds | None = None) -> ResolvedMove:
    """Parse and validate a MOVE document against the SPEC's names.

    Parameters
    ----------
    doc : dict or solver.documents.move.Move
        The document (validated here by :class:`solver.documents.move.Move`), or an instance of that
        model, already validated (the service's request bodies), which is not validated again:
        ``{"handles": {HANDLE: {"translation": [..], "rotation": {...}, "pivot": [..],
        "scale": s}}, "points": {POINT: [x, y, z]}, "relative": {NAME: {"offset": [..]}
        | {"scale": s}}, "features": {FEATURE: {"scale": s}}, "motion": {NAME:
        {"point": [x, y, z]}}, "targets": {NAME: {"amount": a}}}``, and the edits' ``radius``, ``twist``,
        ``map``, ``offset`` and ``lattice``; every field is optional. A handle the MOVE does not name
        stays at its rest position.
    handle_names : sequence of str
    names : dict, optional
        Names the SPEC defines per category (``"points"``, ``"relative"``,
        ``"features"``, ``"motion"``); categories not given accept no names.
    bounds : MoveBounds, optional
        The mesh's extent: translations, offsets, pivots and targets beyond
        ``MOVE_RANGE`` diagonals are refused.

    Returns
    -------
    ResolvedMove

    Raises
    ------
    SpecError
        Unknown fields or names, a value that is not a JSON number, a
        non-finite or out-of-range number; ``details["field"]`` names it.
        A translation, offset, pivot or target beyond ``MOVE_RANGE`` diagonals (and an edit's radius,
        distance or displacement beyond them) has the code ``out_of_range``.

    Examples
    --------
    >>> m = parse_move({"handles": {"h": {"translation": [1, 0, 0]}}}, ["h"])
    >>> m.handles["h"].translation.tolist()
    [1.0, 0.0, 0.0]
    >>> parse_move({"handles": {"h": {"rotation": {"axis": [0, 0, 1], "angle_deg": 370}}}},
    ...            ["h"]).to_dict()["handles"]["h"]["rotation"]["angle_deg"]
    10.0
    """
    from ..documents.move import Move as MoveDoc
    from ..documents.validation import validated

    m = validated(MoveDoc, doc, "MOVE")
    names = names or {}

    def length(x: list[float] | None, where: str) -> np.ndarray:
        v = np.zeros(3) if x is None else np.asarray(x, float)
        return bounds.length(v, where) if bounds is not None else v

    def pos(x: list[float], where: str) -> np.ndarray:
        v = np.asarray(x, float)
        return bounds.position(v, where) if bounds is not None else v

    for key in ("points", "relative", "features", "motion", "targets", *EDIT_KINDS):
        bad = sorted(set(getattr(m, key)) - set(names.get(key, ())))
        expect(not bad, f"MOVE.{key} names unknown {key} {bad}; the SPEC defines {sorted(names.get(key, ()))}",
               field=f"MOVE.{key}", unknown=bad)
    unknown = sorted(set(m.handles) - set(handle_names))
    expect(not unknown, f"MOVE names unknown handle(s) {unknown}; the SPEC defines {sorted(handle_names)}",
           field="MOVE.handles", unknown=unknown)
    out = {}
    for name, h in m.handles.items():
        where = f"MOVE.handles.{name}"
        t = length(h.translation, f"{where}.translation")
        r = _rotation_vector(h.rotation, f"{where}.rotation") if h.rotation is not None else np.zeros(3)
        p = pos(h.pivot, f"{where}.pivot") if h.pivot is not None else None
        out[name] = HandleMove(t, r, 1.0 if h.scale is None else float(h.scale), p)
    points = {k: pos(v, f"MOVE.points.{k}") for k, v in m.points.items()}
    relative: dict[str, dict[str, Any]] = {}
    for k, rel in m.relative.items():
        if rel.offset is not None:
            relative[k] = {"offset": length(rel.offset, f"MOVE.relative.{k}.offset")}
        else:
            relative[k] = {"scale": float(rel.scale)}  # type: ignore[arg-type]  # one of the two, by the model
    features = {k: float(v.scale) for k, v in m.features.items()}
    motion = {k: pos(v.point, f"MOVE.motion.{k}.point") for k, v in m.motion.items()}
    targets = {k: float(v.amount) for k, v in m.targets.items()}
    if any(getattr(m, kind) for kind in EDIT_KINDS):
        from .edit_values import edit_values

        edits = edit_values(m, bounds)
    else:  # no edit: their modules stay unloaded
        edits = {kind: {} for kind in EDIT_KINDS}
    return ResolvedMove(out, points, relative, features, motion, targets, edits)
