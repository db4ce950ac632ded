"""Points on analytic geometry: the nearest of a line, circle, plane, cylinder or sphere, or the hit along a direction.

Each function returns the projected points and a mask of the points that have none: a point on the
axis of a circle or a cylinder, or at the centre of a sphere, has no unique nearest point; a line
along a direction that misses the surface (or runs parallel to it) has no hit.
"""

from __future__ import annotations

import numpy as np

from .edit_entries import MapEntry

__all__ = ["nearest_points", "points_along", "radial", "ON_AXIS"]

#: A point closer than this fraction of the geometry's size (its radius, else the points' spread) to an
#: axis or a centre has no radial direction.
ON_AXIS = 1e-12


def radial(P: np.ndarray, point: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Axial coordinates ``s`` (k,), radial vectors ``w`` (k, 3) and their lengths (k,) of ``P`` about an axis."""
    X = P - point
    s = X @ axis
    w = X - np.outer(s, axis)
    return s, w, np.sqrt(np.einsum("ij,ij->i", w, w))


def _size(e: MapEntry, P: np.ndarray) -> float:
    if e.radius is not None:
        return float(e.radius)
    return float(np.linalg.norm(P.max(axis=0) - P.min(axis=0))) if len(P) else 1.0


def nearest_points(e: MapEntry, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The nearest point of ``e``'s geometry to each point ``P`` (k, 3), and the mask of points without one."""
    c = np.asarray(e.point, np.float64)
    d = np.asarray(e.direction, np.float64) if e.direction is not None else np.zeros(3)
    bad = np.zeros(len(P), bool)
    if e.shape == "line":
        return c + np.outer((P - c) @ d, d), bad
    if e.shape == "plane":
        return P - np.outer((P - c) @ d, d), bad
    assert e.radius is not None
    tiny = ON_AXIS * _size(e, P)
    if e.shape == "sphere":
        w = P - c
        r = np.sqrt(np.einsum("ij,ij->i", w, w))
        bad = r <= tiny
        return c + e.radius * w / np.where(bad, 1.0, r)[:, None], bad
    s, w, r = radial(P, c, d)
    bad = r <= tiny
    u = w / np.where(bad, 1.0, r)[:, None]
    if e.shape == "circle":  # the circle's plane is orthogonal to the normal through the centre
        return c + e.radius * u, bad
    return c + np.outer(s, d) + e.radius * u, bad  # cylinder


def points_along(e: MapEntry, P: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The hit of the line through each point ``P`` along ``u`` (unit) with ``e``'s surface, the nearer one.

    Plane, cylinder or sphere; the mask marks lines that miss it or run parallel to it.
    """
    c = np.asarray(e.point, np.float64)
    if e.shape == "plane":
        n = np.asarray(e.direction, np.float64)
        un = float(u @ n)
        if abs(un) <= 1e-12:
            return P.copy(), np.ones(len(P), bool)
        return P + np.outer(((c - P) @ n) / un, u), np.zeros(len(P), bool)
    assert e.radius is not None
    if e.shape == "cylinder":
        d = np.asarray(e.direction, np.float64)
        _, w0, _ = radial(P, c, d)
        wu = u - (u @ d) * d
    else:  # sphere
        w0, wu = P - c, u
    A = float(wu @ wu)
    if A <= 1e-24:  # along the cylinder's axis: never closer to its wall
        return P.copy(), np.ones(len(P), bool)
    B = w0 @ wu
    C = np.einsum("ij,ij->i", w0, w0) - e.radius ** 2
    disc = B * B - A * C
    bad = disc < 0
    root = np.sqrt(np.where(bad, 0.0, disc))
    # the two roots (-B -+ root) / A, the smaller in magnitude first; q = C / (A t1) is the other, without
    # cancellation
    far = -(B + np.copysign(root, B))
    t_far = far / A
    t_near = np.divide(C, far, out=np.zeros_like(C), where=far != 0)
    t = np.where(np.abs(t_near) <= np.abs(t_far), t_near, t_far)
    return P + np.outer(t, u), bad
