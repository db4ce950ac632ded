"""Symmetry a mesh already has: mirror planes of its boundary nodes, and Abaqus cyclic-symmetry definitions.

:func:`symmetry_candidates` tries the planes through the boundary's centroid
normal to its principal axes and to the coordinate axes, and keeps those
across which (almost) every boundary node has a mirror-image node.
:func:`abaqus_cyclic` reads ``*TIE, CYCLIC SYMMETRY`` and ``*CYCLIC SYMMETRY
MODEL`` of an Abaqus deck. Both return SPEC entries ready to paste
(``SPEC.symmetry`` / ``SPEC.cyclic``, with the selections they need).
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np

from ..mesh import Mesh
from ..ops.closest_point import TriangleSurface
from .matching import rotation

__all__ = ["symmetry_candidates", "abaqus_cyclic", "resolve_cyclic"]


def symmetry_candidates(mesh: Mesh, tol: float = 1e-3, min_fraction: float = 0.999) -> list[dict[str, Any]]:
    """Planes across which the boundary surface mirrors onto itself.

    Each boundary node's mirror image is looked up on the boundary surface
    (a node, or the closest point of a boundary face), so meshes that are not
    themselves symmetric are recognised too (curved faces leave chordal gaps).

    Parameters
    ----------
    mesh : Mesh
    tol : float
        Largest gap relative to the mesh diagonal.
    min_fraction : float
        Share of boundary nodes whose image must lie within ``tol`` of the surface.

    Returns
    -------
    list of dict
        ``{"name", "plane": {"point", "normal"}, "tolerance", "matched", "exact_pairs"}``:
        a ``SPEC.symmetry`` entry each (``tolerance`` a little above the largest
        gap found), with the share of matched nodes and of exact node pairs.

    Examples
    --------
    >>> from solver.mesh import mesh_from_arrays
    >>> from solver.testing import cube_mesh
    >>> [c["plane"]["normal"] for c in symmetry_candidates(mesh_from_arrays(*cube_mesh(2)))][:3]
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    """
    B = np.flatnonzero(mesh.boundary & mesh.referenced)
    if B.size < 4:
        return []
    P = mesh.V[B]
    c = P.mean(axis=0)
    diag = float(np.linalg.norm(P.max(0) - P.min(0)))
    _, _, vt = np.linalg.svd(P - c, full_matrices=False)
    normals: list[np.ndarray] = [np.eye(3)[k] for k in range(3)] + [v / np.linalg.norm(v) for v in vt]
    from scipy.spatial import cKDTree  # scipy.spatial loads on first use

    tree = cKDTree(P)
    surf = TriangleSurface(mesh.V, mesh.F)
    out: list[dict[str, Any]] = []
    seen: list[np.ndarray] = []
    for n in normals:
        if any(abs(float(n @ m)) > 0.999 for m in seen):  # principal axes near a coordinate axis
            continue
        seen.append(n)
        for mid in (0.5 * (P.max(0) + P.min(0)), c):  # the box's middle first: exact for CAD parts
            M = P - 2.0 * np.outer((P - mid) @ n, n)
            d_node, _ = tree.query(M)
            d = np.minimum(d_node, surf.closest(M).dist)
            frac = float((d <= tol * diag).mean())
            if frac >= min_fraction:
                nn = np.where(np.abs(n) < 1e-12, 0.0, n)
                gap = float(d[d <= tol * diag].max())
                out.append({"name": f"mirror{len(out) + 1}",
                            "plane": {"point": [float(x) for x in mid], "normal": [float(x) for x in nn]},
                            "tolerance": float(f"{max(2.0 * gap, 1e-9 * diag):.2g}"), "matched": frac,
                            "exact_pairs": float((d_node <= 1e-9 * diag).mean())})
                break
    return sorted(out, key=lambda e: -e["matched"])


_KEY = re.compile(rb"^\s*\*\s*([a-z ]+?)\s*(,.*)?$", re.IGNORECASE)


def _params(text: bytes) -> dict[str, str]:
    out = {}
    for part in text.split(b",")[1:]:
        if b"=" in part:
            k, v = part.split(b"=", 1)
            out[k.strip().upper().decode()] = v.strip().decode()
        elif part.strip():
            out[part.strip().upper().decode()] = ""
    return out


def abaqus_cyclic(raw: bytes | None) -> list[dict[str, Any]]:
    r"""``SPEC.cyclic`` entries from an Abaqus deck's ``*TIE, CYCLIC SYMMETRY`` and ``*CYCLIC SYMMETRY MODEL``.

    Node surfaces (``*SURFACE, TYPE=NODE``) are resolved to their node sets.
    Abaqus names the slave surface first: the entry's faces are ``[master,
    slave]`` (A maps onto B). The sector angle is ``360 / N``; its sign (which
    way A turns onto B) depends on the geometry: :func:`resolve_cyclic` picks it.

    Examples
    --------
    >>> deck = (b"*SURFACE,NAME=l,TYPE=NODE\nNL\n*SURFACE,NAME=r,TYPE=NODE\nNR\n"
    ...         b"*TIE,POSITION TOLERANCE=0.001,CYCLIC SYMMETRY,NAME=T1\nl,r\n"
    ...         b"*CYCLIC SYMMETRY MODEL,N=12\n0.,0.,0.,1.,0.,0.\n")
    >>> abaqus_cyclic(deck)[0]["faces"], abaqus_cyclic(deck)[0]["angle_deg"]
    (['NR', 'NL'], 30.0)
    """
    if not raw:
        return []
    lines = [ln.rstrip(b"\r") for ln in raw.splitlines() if not ln.lstrip().startswith(b"**")]
    surfaces: dict[str, str] = {}
    ties: list[tuple[str, str, str, float | None]] = []
    model: tuple[int, list[float]] | None = None
    for k, ln in enumerate(lines):
        m = _KEY.match(ln)
        if not m:
            continue
        key = m.group(1).decode().upper().strip()
        par = _params(ln)
        data = lines[k + 1] if k + 1 < len(lines) and not lines[k + 1].lstrip().startswith(b"*") else b""
        if key == "SURFACE" and par.get("TYPE", "").upper() == "NODE" and "NAME" in par and data:
            surfaces[par["NAME"]] = data.split(b",")[0].strip().decode()
        elif key == "TIE" and "CYCLIC SYMMETRY" in par and data:
            a, b = (x.strip().decode() for x in data.split(b",")[:2])
            tol = float(par["POSITION TOLERANCE"]) if "POSITION TOLERANCE" in par else None
            ties.append((par.get("NAME", "tie"), a, b, tol))
        elif key == "CYCLIC SYMMETRY MODEL" and "N" in par and data:
            vals = [float(x) for x in data.replace(b",", b" ").split()[:6]]
            model = (int(par["N"]), vals)
    if model is None or not ties:
        return []
    n, pts = model
    p, q = np.array(pts[:3]), np.array(pts[3:6])
    d = q - p
    d = d / np.linalg.norm(d)
    out = []
    for name, slave, master, tol in ties:
        entry: dict[str, Any] = {"name": name, "axis": {"point": p.tolist(), "direction": d.tolist()},
                                 "angle_deg": 360.0 / n, "faces": [surfaces.get(master, master),
                                                                   surfaces.get(slave, slave)]}
        if tol is not None:
            entry["tolerance"] = tol
        out.append(entry)
    return out


def resolve_cyclic(mesh: Mesh, entry: dict[str, Any]) -> dict[str, Any]:
    """The entry with the angle's sign that turns face A onto face B (their node sets, by coordinates)."""
    a = mesh.sets.get(entry["faces"][0])
    b = mesh.sets.get(entry["faces"][1])
    if a is None or b is None or not len(a) or not len(b):
        return entry
    from scipy.spatial import cKDTree  # scipy.spatial loads on first use

    tree = cKDTree(mesh.V[b])
    best = None
    for sign in (1.0, -1.0):
        R, t = rotation(np.asarray(entry["axis"]["point"]), np.asarray(entry["axis"]["direction"]),
                        sign * entry["angle_deg"])
        gap = float(tree.query(mesh.V[a] @ R.T + t)[0].max())
        if best is None or gap < best[0]:
            best = (gap, sign)
    assert best is not None
    return {**entry, "angle_deg": best[1] * entry["angle_deg"]}
