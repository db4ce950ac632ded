"""Shape variables: named basis MOVEs, and the MOVE of a parameter vector.

A SHAPES document ``{"shapes": {NAME: MOVE, ...}}`` names basis shapes, each
the MOVE at parameter value 1 (HyperMorph's saved shapes, RBF Morph's shape
parameters). A variant with parameters ``theta`` (one per shape) is the sum
of the shapes, each weighted by its value:

* handle translations, relative offsets, point and motion targets, and
  target-surface amounts add (points, motion points and offsets as
  displacements from their values at rest, so ``theta = 0`` is the rest shape);
* handle rotations add as quaternion logarithms, per handle
  (``r_h = sum_k theta_k r_kh``, ``r = (angle / 2) axis``: the quantity the
  rotation field propagates, Masuda & Ogawa eq. 3.5-3.9, ECLS eq. 24-27);
* handle, feature and relative scales multiply as ``s ** theta``
  (their logarithms add, as the rotation field's log-scales do);
* the edits' parameters add: radius, fillet-radius, distance and angle changes
  (a shape's new value counts as its change from the edit's nominal rest value),
  twist rates or twist tables (over every row's position), map amounts, offset
  distances and control-point displacements.

Every part of the variant is linear in ``theta`` except the exponential maps:
the rotation matrices of the logarithms and ``exp`` of the log-scales.
:mod:`solver.workflows.sensitivities` differentiates through exactly those.

:func:`parse_shapes` is strict. Each shape is parsed as a MOVE against the
SPEC (an unknown handle or name, a bad number raises
:class:`~solver.errors.SpecError` naming the shape); shapes that turn or scale
one handle must do so about one pivot; a relative constraint gets offsets or
scales, not both. Error codes: ``invalid_shapes`` (the document),
``pivot_conflict``, ``relative_conflict``, ``twist_conflict`` (a twist given a
linear law by one shape and a table by another), ``rotation_range`` (a variant turns
a handle by 360 degrees or more, which a MOVE cannot express), and the MOVE
parser's own (``invalid_spec``) with ``details["shape"]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..constraints.edit_values import EditValue, TwistValue, as_change, combined_value
from ..constraints.move import ResolvedMove
from ..deform.deformer import Deformer
from ..documents.shapes import RESERVED
from ..errors import SpecError

__all__ = ["Shapes", "LinearTarget", "parse_shapes", "combine", "variant_move", "PIVOT_TOL", "RESERVED"]

#: Pivots of one handle closer than this fraction of the mesh diagonal are one pivot.
PIVOT_TOL = 1e-9


@dataclass(frozen=True, eq=False)
class LinearTarget:
    """A MOVE target that is linear in the parameters: ``value = base + sum_k theta_k step[k]``.

    Attributes
    ----------
    base : (3,) float array
        The value with every parameter 0 (the MOVE ``{}``).
    step : (K, 3) float array
        What each shape adds at value 1 (zero for shapes that do not name it).
    """

    base: np.ndarray
    step: np.ndarray

    def at(self, theta: np.ndarray) -> np.ndarray:
        """The value (3,) at parameters ``theta`` (K,)."""
        return self.base + theta @ self.step


@dataclass(frozen=True, eq=False)
class Shapes:
    """Parsed basis shapes of one deformer (immutable).

    Attributes
    ----------
    names : tuple of str
        Shape names in document order; parameter ``k`` belongs to ``names[k]``.
    documents : dict of str to dict
        Each shape's MOVE document as given (validated).
    handles : tuple of str
        Every handle of the SPEC (the deformer's order); ``H = len(handles)``.
    moved : (H,) bool array
        Handles some shape names (the variants' MOVEs list these).
    translation : (K, H, 3) float array
        Handle translations per shape.
    log_rotation : (K, H, 3) float array
        Handle quaternion logarithms ``(theta / 2) axis`` per shape.
    log_scale : (K, H) float array
        Logarithms of the handle scales per shape.
    pivots : dict of str to (3,) array or None
        The pivot of each moved handle: a shape's explicit one, or None (the
        handle's rest centroid, as in a MOVE).
    centroids : dict of str to (3,) array
        Each handle's rest centroid (its default pivot).
    points, motion, offsets : dict of str to LinearTarget
        SPEC point targets, motion points and relative offsets some shape names.
    relative_log_scale, feature_log_scale : dict of str to (K,) float array
        Logarithms of relative and feature scales per shape.
    target_amount : dict of str to (K,) float array
        Target-surface amounts per shape (MOVE ``targets``).
    edits : dict of str to dict of str to tuple
        Per edit kind and name, each shape's value at parameter 1 (None: the shape leaves it at rest);
        radius values are changes (``delta``).
    """

    names: tuple[str, ...]
    documents: dict[str, dict[str, Any]]
    handles: tuple[str, ...]
    moved: np.ndarray
    translation: np.ndarray
    log_rotation: np.ndarray
    log_scale: np.ndarray
    pivots: dict[str, np.ndarray | None]
    centroids: dict[str, np.ndarray]
    points: dict[str, LinearTarget]
    motion: dict[str, LinearTarget]
    offsets: dict[str, LinearTarget]
    relative_log_scale: dict[str, np.ndarray]
    feature_log_scale: dict[str, np.ndarray]
    target_amount: dict[str, np.ndarray]
    edits: dict[str, dict[str, tuple[EditValue | None, ...]]] = field(default_factory=dict)

    @property
    def count(self) -> int:
        """Number of shapes (parameters), K."""
        return len(self.names)

    def vector(self, values: dict[str, float]) -> np.ndarray:
        """Parameters (K,) from ``{shape: value}`` (shapes not named are 0).

        Raises
        ------
        SpecError
            A name that is not a shape.
        """
        unknown = sorted(set(values) - set(self.names))
        if unknown:
            raise SpecError(f"unknown shape(s) {unknown}; the shapes are {list(self.names)}",
                            code="unknown_shape", unknown=unknown)
        return np.array([float(values.get(n, 0.0)) for n in self.names])


def _shape_error(name: str, e: SpecError) -> SpecError:
    details = {k: v for k, v in e.details.items() if k != "shape"}
    return SpecError(f"shape {name!r}: {e.message}", code=e.code, shape=name, **details)


def parse_shapes(doc: Any, deformer: Deformer) -> Shapes:
    """Parse and validate a SHAPES document against a deformer's SPEC.

    Parameters
    ----------
    doc : dict or solver.documents.shapes.Shapes
        ``{"shapes": {NAME: MOVE, ...}}``, at least one shape; each MOVE is a
        MOVE document (:func:`~solver.constraints.move.parse_move`) at value 1.
        A dict is validated by :class:`solver.documents.shapes.Shapes`; an
        instance of it is taken as validated.
    deformer : Deformer

    Returns
    -------
    Shapes

    Raises
    ------
    SpecError
        A malformed document, a MOVE the SPEC refuses (naming the shape),
        shapes turning one handle about different pivots, offsets and scales
        of one relative constraint.

    Examples
    --------
    >>> from solver import mesh_from_arrays, precompute
    >>> from solver.testing import cube_mesh
    >>> d = precompute(mesh_from_arrays(*cube_mesh(2)), {
    ...     "selections": {"a": {"box": {"min": [0, 0, 0], "max": [1, 1, 0]}},
    ...                    "b": {"box": {"min": [0, 0, 1], "max": [1, 1, 1]}}},
    ...     "fixed": ["a"], "handles": {"top": "b"}})
    >>> s = parse_shapes({"shapes": {"lift": {"handles": {"top": {"translation": [0, 0, 0.1]}}}}}, d)
    >>> s.names, s.translation[0, 0].tolist()
    (('lift',), [0.0, 0.0, 0.1])
    """
    from ..documents.shapes import Shapes as ShapesDoc
    from ..documents.validation import describe, validated

    if not isinstance(doc, (dict, ShapesDoc)) or (isinstance(doc, dict) and set(doc) != {"shapes"}):
        keys = sorted(doc) if isinstance(doc, dict) else type(doc).__name__
        raise SpecError(f"a SHAPES document is {{\"shapes\": {{NAME: MOVE, ...}}}}, got {keys}",
                        code="invalid_shapes", field="shapes")
    try:
        model = validated(ShapesDoc, doc, "SHAPES")
    except SpecError as e:
        first = e.details["errors"][0]
        loc = tuple(first["loc"])
        if len(loc) > 2 and loc[0] == "shapes":  # inside one shape's MOVE: named as the MOVE parser names it
            field, _, text = describe("MOVE", loc[2:], {"type": first["type"], "msg": first["msg"]})
            got = "" if first["type"] == "extra_forbidden" else first["got"]
            raise SpecError(f"shape {loc[1]!r}: {text}{got}", shape=str(loc[1]), field=field) from None
        raise SpecError(e.message, code="invalid_shapes", **e.details) from None
    shapes = model.shapes
    names = tuple(shapes)
    K, handles = len(names), tuple(deformer.handle_names)
    H = len(handles)
    cs = deformer.data.constraints
    rest = cs.rest
    moves: dict[str, ResolvedMove] = {}
    for name in names:
        try:
            moves[name] = deformer.parse_move(shapes[name])
        except SpecError as e:
            raise _shape_error(name, e) from None
    T, R, S = np.zeros((K, H, 3)), np.zeros((K, H, 3)), np.zeros((K, H))
    moved = np.zeros(H, bool)
    pivots: dict[str, np.ndarray | None] = {}
    pivot_of: dict[str, tuple[str, np.ndarray]] = {}
    centroids = {h: np.asarray(cs.handle_pivots[h], np.float64) for h in handles}
    for k, name in enumerate(names):
        for h, hname in enumerate(handles):
            hm = moves[name].handles.get(hname)
            if hm is None:
                continue
            moved[h] = True
            T[k, h], R[k, h], S[k, h] = hm.translation, hm.log_rotation, math.log(hm.scale)
            if not (np.any(hm.log_rotation) or hm.scale != 1.0):
                continue  # a pivot does not act on a translation
            p = centroids[hname] if hm.pivot is None else np.asarray(hm.pivot, np.float64)
            if hname in pivot_of:
                other, q = pivot_of[hname]
                if np.linalg.norm(p - q) > PIVOT_TOL * max(cs.diag, 1e-300):
                    raise SpecError(f"shapes {other!r} and {name!r} turn or scale handle {hname!r} about "
                                    f"different pivots {q.tolist()} and {p.tolist()} (a missing pivot is the "
                                    "handle's rest centroid); give them one pivot", code="pivot_conflict",
                                    shape=name, other=other, handle=hname)
            else:
                pivot_of[hname] = (name, p)
                pivots[hname] = None if hm.pivot is None else p
    for h, hname in enumerate(handles):
        if moved[h] and hname not in pivots:
            pivots[hname] = None

    def linear(base_of: dict[str, np.ndarray], get: Any) -> dict[str, LinearTarget]:
        out = {}
        for key, base in base_of.items():
            named = [k for k, n in enumerate(names) if key in get(moves[n])]
            if not named:
                continue
            step = np.zeros((K, 3))
            for k in named:
                step[k] = np.asarray(get(moves[names[k]])[key], np.float64) - base
            out[key] = LinearTarget(np.asarray(base, np.float64), step)
        return out

    point_base = {k: (r0 if tgt is None else np.asarray(tgt, np.float64)) for k, (r0, tgt) in rest.points.items()}
    points = linear(point_base, lambda mv: mv.points)
    motion = linear(dict(rest.motion), lambda mv: mv.motion)
    offsets = linear(dict(rest.relative),
                     lambda mv: {k: v["offset"] for k, v in mv.relative.items() if "offset" in v})
    rel_scale: dict[str, np.ndarray] = {}
    for k, name in enumerate(names):
        for key, v in moves[name].relative.items():
            if "scale" in v:
                rel_scale.setdefault(key, np.zeros(K))[k] = math.log(v["scale"])
    for key in sorted(set(rel_scale) & set(offsets)):
        a = next(n for n in names if "offset" in moves[n].relative.get(key, {}))
        b = next(n for n in names if "scale" in moves[n].relative.get(key, {}))
        raise SpecError(f"shapes {a!r} and {b!r} give relative constraint {key!r} an offset and a scale; "
                        "a variant needs one of them", code="relative_conflict", shape=b, other=a, relative=key)
    feat_scale: dict[str, np.ndarray] = {}
    for k, name in enumerate(names):
        for key, s in moves[name].features.items():
            feat_scale.setdefault(key, np.zeros(K))[k] = math.log(s)
    amounts: dict[str, np.ndarray] = {}
    for k, name in enumerate(names):
        for target, tm in shapes[name].targets.items():  # the document's amounts (a MOVE parser may drop them)
            amounts.setdefault(target, np.zeros(K))[k] = tm.amount
    return Shapes(names=names, documents={n: shapes[n].dump() for n in names}, handles=handles, moved=moved,
                  translation=T, log_rotation=R, log_scale=S, pivots=pivots, centroids=centroids, points=points,
                  motion=motion, offsets=offsets, relative_log_scale=rel_scale, feature_log_scale=feat_scale,
                  target_amount=amounts, edits=_edit_steps(names, moves, rest.nominal))


def _edit_steps(names: tuple[str, ...], moves: dict[str, ResolvedMove], nominal: dict[str, dict[str, float]]
                ) -> dict[str, dict[str, tuple[EditValue | None, ...]]]:
    """Each shape's value of every edit some shape names; a new radius, distance or angle as its change."""
    steps: dict[str, dict[str, list[EditValue | None]]] = {}
    for k, name in enumerate(names):
        for kind, named in moves[name].edits.items():
            for edit, v in named.items():
                v = as_change(v, nominal.get(kind, {}).get(edit))
                steps.setdefault(kind, {}).setdefault(edit, [None] * len(names))[k] = v
    for edit, values in steps.get("twist", {}).items():
        laws = [(names[k], "table" if v.rate is None else "linear") for k, v in enumerate(values)
                if isinstance(v, TwistValue)]
        if len({law for _, law in laws}) > 1:
            a = next(n for n, law in laws if law == "linear")
            b = next(n for n, law in laws if law == "table")
            raise SpecError(f"shapes {a!r} and {b!r} give twist {edit!r} a linear law and a table; a variant needs "
                            "one kind of law", code="twist_conflict", shape=b, other=a, twist=edit)
    return {kind: {edit: tuple(v) for edit, v in named.items()} for kind, named in steps.items()}


def _check_theta(shapes: Shapes, theta: Any, where: str) -> np.ndarray:
    th = np.asarray(theta, np.float64)
    if th.shape != (shapes.count,) or not np.isfinite(th).all():
        raise SpecError(f"{where}: parameters must be {shapes.count} finite numbers (one per shape), "
                        f"got {np.asarray(theta).tolist()}", code="invalid_plan")
    return th


def combine(shapes: Shapes, theta: Any, where: str = "variant") -> dict[str, Any]:
    """The MOVE document of the variant with parameters ``theta``.

    Parameters
    ----------
    shapes : Shapes
    theta : (K,) array_like
        One value per shape (``shapes.names`` order).
    where : str
        Names the variant in error messages (``"plan row 3"``).

    Returns
    -------
    dict
        A MOVE document: every handle and target some shape names, the rest
        absent (at rest). Rotations are written as axis and angle, which the
        MOVE parser turns back into the same logarithm.

    Raises
    ------
    SpecError
        Parameters of the wrong length or not finite; a handle turned by 360
        degrees or more (``rotation_range``).
    """
    th = _check_theta(shapes, theta, where)
    handles: dict[str, Any] = {}
    t = np.einsum("k,khc->hc", th, shapes.translation)
    r = np.einsum("k,khc->hc", th, shapes.log_rotation)
    ls = th @ shapes.log_scale
    for h, name in enumerate(shapes.handles):
        if not shapes.moved[h]:
            continue
        hd: dict[str, Any] = {"translation": t[h].tolist()}
        half = float(np.linalg.norm(r[h]))
        if half > 0.0:
            deg = math.degrees(2.0 * half)
            if deg >= 360.0:
                raise SpecError(f"{where}: handle {name!r} turns by {deg:.6g} degrees; a MOVE turns a handle by "
                                "less than 360", code="rotation_range", handle=name, angle_deg=deg)
            hd["rotation"] = {"axis": (r[h] / half).tolist(), "angle_deg": deg}
        if ls[h] != 0.0:
            hd["scale"] = math.exp(float(ls[h]))
        pivot = shapes.pivots.get(name)
        if pivot is not None:
            hd["pivot"] = pivot.tolist()
        handles[name] = hd
    doc: dict[str, Any] = {"handles": handles}
    if shapes.points:
        doc["points"] = {k: v.at(th).tolist() for k, v in shapes.points.items()}
    rel: dict[str, Any] = {k: {"offset": v.at(th).tolist()} for k, v in shapes.offsets.items()}
    rel.update({k: {"scale": math.exp(float(th @ v))} for k, v in shapes.relative_log_scale.items()})
    if rel:
        doc["relative"] = rel
    if shapes.feature_log_scale:
        doc["features"] = {k: {"scale": math.exp(float(th @ v))} for k, v in shapes.feature_log_scale.items()}
    if shapes.motion:
        doc["motion"] = {k: {"point": v.at(th).tolist()} for k, v in shapes.motion.items()}
    if shapes.target_amount:
        doc["targets"] = {k: {"amount": float(th @ v)} for k, v in shapes.target_amount.items()}
    for kind, named in shapes.edits.items():
        doc[kind] = {edit: combined_value(kind, list(steps), th).to_dict() for edit, steps in named.items()}
    return doc


def variant_move(deformer: Deformer, shapes: Shapes, theta: Any, where: str = "variant") -> ResolvedMove:
    """The parsed MOVE of the variant with parameters ``theta`` (:func:`combine`, then the MOVE parser).

    Raises
    ------
    SpecError
        As :func:`combine`, or the variant's MOVE is out of range (a scale
        beyond the MOVE parser's range, a translation beyond its bound); the
        message starts with ``where``.
    """
    doc = combine(shapes, theta, where)
    try:
        return deformer.parse_move(doc)
    except SpecError as e:
        raise SpecError(f"{where}: {e.message}", code=e.code, **e.details) from None
