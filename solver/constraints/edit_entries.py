"""The SPEC's daily edits as frozen entries, from ``radius`` to ``angle``.

:func:`edit_entries` turns the validated document's lists (:mod:`solver.documents.edits`) into
:class:`RadiusEntry`, :class:`TwistEntry`, :class:`MapEntry`, :class:`OffsetEntry`,
:class:`LatticeEntry`, :class:`FilletEntry`, :class:`DistanceEntry` and :class:`AngleEntry`, their
selection names resolved; :func:`solver.constraints.resolve_edits.resolve_edits`
resolves them on a mesh.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import SpecError
from .edit_kinds import EDIT_KINDS

__all__ = ["RadiusEntry", "TwistEntry", "MapEntry", "OffsetEntry", "LatticeEntry", "FilletEntry", "DistanceEntry",
           "AngleEntry", "EditEntry", "edit_entries", "EDIT_KINDS"]

Vec = tuple[float, float, float]


def _vec(v: Any) -> Vec:
    x, y, z = (float(c) for c in v)
    return (x, y, z)


def _unit(v: Any) -> Vec:
    a = np.asarray(v, np.float64)
    return _vec(a / np.linalg.norm(a))


@dataclass(frozen=True)
class RadiusEntry:
    """A cylindrical feature whose radius a MOVE sets; ``point`` and ``direction`` None: the axis is fitted."""

    index: int
    name: str
    selection: str
    point: Vec | None = None
    direction: Vec | None = None
    kind: str = "radius"

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry."""
        out: dict[str, Any] = {"name": self.name, "selection": self.selection}
        if self.point is not None and self.direction is not None:
            out["axis"] = {"point": list(self.point), "direction": list(self.direction)}
        return out


@dataclass(frozen=True)
class TwistEntry:
    """Nodes turned (``mode`` twist) or bent toward ``toward`` (bend) along the axis through ``point``.

    ``direction`` and ``toward`` are unit vectors; ``toward`` is orthogonal to ``direction`` (None for a twist).
    """

    index: int
    name: str
    selection: str
    point: Vec
    direction: Vec
    mode: str = "twist"
    toward: Vec | None = None
    kind: str = "twist"

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry."""
        out: dict[str, Any] = {"name": self.name, "selection": self.selection, "mode": self.mode,
                               "axis": {"point": list(self.point), "direction": list(self.direction)}}
        if self.toward is not None:
            out["toward"] = list(self.toward)
        return out


#: The field names of each geometry's point, direction and radius in the document.
_GEOMETRY_FIELDS = {"line": ("point", "direction", None), "circle": ("center", "normal", "radius"),
                    "plane": ("point", "normal", None), "cylinder": ("point", "axis", "radius"),
                    "sphere": ("center", None, "radius")}


@dataclass(frozen=True)
class MapEntry:
    """Nodes mapped onto an analytic geometry.

    Attributes
    ----------
    shape : {"line", "circle", "plane", "cylinder", "sphere"}
    point : tuple
        The line's or the plane's point, the circle's or the sphere's centre, a point of the cylinder's axis.
    direction : tuple or None
        Unit: the line's direction, the circle's or the plane's normal, the cylinder's axis; None for a sphere.
    radius : float or None
    projection : {"nearest", "along"}
    along : tuple or None
        Unit direction of an ``along`` projection.
    """

    index: int
    name: str
    selection: str
    shape: str
    point: Vec
    direction: Vec | None
    radius: float | None
    projection: str = "nearest"
    along: Vec | None = None
    kind: str = "map"

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry."""
        p, d, r = _GEOMETRY_FIELDS[self.shape]
        geo: dict[str, Any] = {p: list(self.point)}
        if d is not None and self.direction is not None:
            geo[d] = list(self.direction)
        if r is not None:
            geo[r] = self.radius
        out: dict[str, Any] = {"name": self.name, "selection": self.selection, "geometry": {self.shape: geo},
                               "projection": self.projection}
        if self.along is not None:
            out["direction"] = list(self.along)
        return out


@dataclass(frozen=True)
class OffsetEntry:
    """A face set moved along its outward normal; ``opposite`` held, or moved half the distance (``symmetric``)."""

    index: int
    name: str
    selection: str
    opposite: str | None = None
    symmetric: bool = False
    planar_deg: float = 1.0
    kind: str = "offset"

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry."""
        out: dict[str, Any] = {"name": self.name, "selection": self.selection, "symmetric": self.symmetric,
                               "planar_deg": self.planar_deg}
        if self.opposite is not None:
            out["opposite"] = self.opposite
        return out


@dataclass(frozen=True)
class LatticeEntry:
    """A morph volume: a box, ``counts`` control points per axis, the nodes it moves (None: boundary nodes inside)."""

    index: int
    name: str
    lo: Vec
    hi: Vec
    counts: tuple[int, int, int]
    selection: str | None = None
    kind: str = "lattice"

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry."""
        out: dict[str, Any] = {"name": self.name, "box": {"min": list(self.lo), "max": list(self.hi)},
                               "counts": list(self.counts)}
        if self.selection is not None:
            out["selection"] = self.selection
        return out


@dataclass(frozen=True)
class FilletEntry:
    """A fillet whose radius a MOVE sets: its nodes ``selection``, tangent to the planar faces ``faces``."""

    index: int
    name: str
    selection: str
    faces: tuple[str, str]
    kind: str = "fillet"

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry."""
        return {"name": self.name, "selection": self.selection, "faces": list(self.faces)}


@dataclass(frozen=True)
class DistanceEntry:
    """The distance from ``reference`` to ``selection`` (which moves): between centroids, or along ``direction``."""

    index: int
    name: str
    selection: str
    reference: str
    direction: Vec | None = None
    kind: str = "distance"

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry."""
        out: dict[str, Any] = {"name": self.name, "selection": self.selection, "reference": self.reference}
        if self.direction is not None:
            out["direction"] = list(self.direction)
        return out


@dataclass(frozen=True)
class AngleEntry:
    """The angle between the directions of ``selection`` (which turns) and ``reference``; None: fitted or default.

    ``direction``, ``reference_direction`` and ``axis`` are unit vectors.
    """

    index: int
    name: str
    selection: str
    reference: str
    direction: Vec | None = None
    reference_direction: Vec | None = None
    axis: Vec | None = None
    pivot: Vec | None = None
    planar_deg: float = 1.0
    kind: str = "angle"

    def to_dict(self) -> dict[str, Any]:
        """SPEC form of the entry."""
        out: dict[str, Any] = {"name": self.name, "selection": self.selection, "reference": self.reference,
                               "planar_deg": self.planar_deg}
        for key in ("direction", "reference_direction", "axis", "pivot"):
            v = getattr(self, key)
            if v is not None:
                out[key] = list(v)
        return out


EditEntry = (RadiusEntry | TwistEntry | MapEntry | OffsetEntry | LatticeEntry | FilletEntry | DistanceEntry
             | AngleEntry)


def edit_entries(d: dict[str, Any], known: Callable[..., str]) -> tuple[EditEntry, ...]:
    """The edits of a validated SPEC document ``d``, in :data:`EDIT_KINDS` order, their selections resolved.

    Raises
    ------
    SpecError
        A selection that is not defined; a name used twice within one kind.
    """
    out: list[EditEntry] = []
    for kind in EDIT_KINDS:
        names: list[str] = []
        for k, e in enumerate(d.get(kind) or []):
            where = f"SPEC.{kind}[{k}]"
            sel = known(e["selection"], f"{where}.selection", where) if e.get("selection") is not None else None
            names.append(e["name"])
            out.append(_entry(kind, k, e, sel, where, known))
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise SpecError(f"SPEC.{kind}: name(s) {dup} used twice", field=kind, names=dup)
    return tuple(out)


def _entry(kind: str, k: int, e: dict[str, Any], sel: str | None, where: str, known: Callable[..., str]) -> EditEntry:
    name = e["name"]
    if kind == "radius":
        ax = e.get("axis")
        assert sel is not None
        return RadiusEntry(k, name, sel, _vec(ax["point"]) if ax else None, _unit(ax["direction"]) if ax else None)
    if kind == "twist":
        assert sel is not None
        d = np.asarray(_unit(e["axis"]["direction"]))
        toward = None
        if e.get("toward") is not None:  # orthogonal to the axis (the model refused one along it)
            t = np.asarray(e["toward"], np.float64)
            toward = _unit(t - (t @ d) * d)
        return TwistEntry(k, name, sel, _vec(e["axis"]["point"]), _vec(d), e.get("mode", "twist"), toward)
    if kind == "map":
        assert sel is not None
        (shape, geo), = e["geometry"].items()
        p, dname, r = _GEOMETRY_FIELDS[shape]
        return MapEntry(k, name, sel, shape, _vec(geo[p]), _unit(geo[dname]) if dname else None,
                        float(geo[r]) if r else None, e.get("projection", "nearest"),
                        _unit(e["direction"]) if e.get("direction") is not None else None)
    if kind == "fillet":
        assert sel is not None
        a, b = (known(f, f"{where}.faces[{i}]", where) for i, f in enumerate(e["faces"]))
        return FilletEntry(k, name, sel, (a, b))
    if kind in ("distance", "angle"):
        assert sel is not None
        ref = known(e["reference"], f"{where}.reference", where)

        def unit(key: str) -> Vec | None:
            return _unit(e[key]) if e.get(key) is not None else None

        if kind == "distance":
            return DistanceEntry(k, name, sel, ref, unit("direction"))
        return AngleEntry(k, name, sel, ref, unit("direction"), unit("reference_direction"), unit("axis"),
                          _vec(e["pivot"]) if e.get("pivot") is not None else None,
                          float(e.get("planar_deg", 1.0)))
    if kind == "offset":
        assert sel is not None
        opp = e.get("opposite")
        return OffsetEntry(k, name, sel, known(opp, f"{where}.opposite", where) if opp is not None else None,
                           bool(e.get("symmetric", False)), float(e.get("planar_deg", 1.0)))
    c = e["counts"]
    return LatticeEntry(k, name, _vec(e["box"]["min"]), _vec(e["box"]["max"]), (int(c[0]), int(c[1]), int(c[2])),
                        sel)
