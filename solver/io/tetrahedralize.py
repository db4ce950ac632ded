"""Tetrahedralize a closed triangle surface with fTetWild (pytetwild).

The result is a validated :class:`~solver.mesh.Mesh` with every tetrahedron
positively oriented; an output that is not a manifold tet mesh is retried once
with a tighter envelope.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import InvalidMeshError
from ..limits import EDGE_LENGTH_FAC_MAX, EDGE_LENGTH_FAC_MIN, ENVELOPE_MAX
from ..mesh import Mesh, mesh_from_arrays
from ..ops.unique import unique
from ..validity.quality import signed_volumes

__all__ = ["tetrahedralize", "open_edges", "check_edge_length"]

#: File fTetWild writes into the working directory on every run.
TRACKED_SURFACE = "__tracked_surface.stl"


def open_edges(F: np.ndarray) -> np.ndarray:
    """Edges of a triangle surface not shared by exactly two triangles.

    Parameters
    ----------
    F : (k, 3) int array

    Returns
    -------
    (e, 2) int array
        Sorted vertex pairs of the border and non-manifold edges.

    Examples
    --------
    >>> open_edges(np.array([[0, 1, 2]])).tolist()
    [[0, 1], [0, 2], [1, 2]]
    """
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    uniq, counts = np.unique(E, axis=0, return_counts=True)
    return uniq[counts != 2]


def check_edge_length(V: np.ndarray, edge_length: float | None, edge_length_fac: float,
                      epsilon: float = 1e-3) -> float:
    """The target edge length relative to the bounding-box diagonal of ``V``, checked against its bounds.

    Parameters
    ----------
    V : (n, 3) float array
        Surface vertices.
    edge_length : float or None
        Absolute target edge length; when given, it decides (``edge_length_fac`` is not used).
    edge_length_fac : float
        Target edge length / bounding-box diagonal.
    epsilon : float
        Envelope / bounding-box diagonal.

    Returns
    -------
    float
        The relative edge length fTetWild will aim at.

    Raises
    ------
    InvalidMeshError
        ``out_of_range`` naming the ``field`` (``edge_length``, ``edge_length_fac`` or ``epsilon``),
        the value, the bounds and the diagonal, when a length lies outside
        [:data:`~solver.limits.EDGE_LENGTH_FAC_MIN`, :data:`~solver.limits.EDGE_LENGTH_FAC_MAX`] of the
        diagonal or the envelope outside (0, :data:`~solver.limits.ENVELOPE_MAX`].

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [3, 0, 0], [0, 4, 0], [0, 0, 0]])
    >>> check_edge_length(V, 0.5, 0.05)
    0.1
    """
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) if len(V) else 0.0
    if not (np.isfinite(epsilon) and 0 < epsilon <= ENVELOPE_MAX):
        raise InvalidMeshError(f"epsilon {epsilon!r} lies outside (0, {ENVELOPE_MAX:g}] (a fraction of the "
                               "bounding-box diagonal)", code="out_of_range", field="epsilon", value=epsilon,
                               min=0.0, max=ENVELOPE_MAX)
    if edge_length is None:
        field, value, rel = "edge_length_fac", edge_length_fac, edge_length_fac
    else:
        field, value = "edge_length", edge_length
        rel = edge_length / diag if diag > 0 and np.isfinite(edge_length) else float("nan")
    if not (np.isfinite(rel) and EDGE_LENGTH_FAC_MIN <= rel <= EDGE_LENGTH_FAC_MAX):
        absolute = (f" (of a bounding-box diagonal of {diag:.6g}: between {EDGE_LENGTH_FAC_MIN * diag:.6g} and "
                    f"{EDGE_LENGTH_FAC_MAX * diag:.6g})" if field == "edge_length" else "")
        raise InvalidMeshError(
            f"{field} {value!r} lies outside [{EDGE_LENGTH_FAC_MIN:g}, {EDGE_LENGTH_FAC_MAX:g}] of the "
            f"bounding-box diagonal{absolute}", code="out_of_range", field=field, value=value,
            min=EDGE_LENGTH_FAC_MIN * (diag if field == "edge_length" else 1.0),
            max=EDGE_LENGTH_FAC_MAX * (diag if field == "edge_length" else 1.0), diagonal=diag)
    return float(rel)


def tetrahedralize(V: Any, F: Any, edge_length: float | None = None, edge_length_fac: float = 0.05,
                   epsilon: float = 1e-3, optimize: bool = True, allow_open: bool = False, retry: bool = True,
                   log: Callable[[str], None] | None = None, threads: int = 0,
                   stage: Callable[[str], None] | None = None) -> tuple[Mesh, dict[str, Any]]:
    """Fill a closed surface with tetrahedra (fTetWild), checked as a manifold tet mesh.

    fTetWild's output is validated like any input mesh (:func:`solver.mesh.validate`).
    When it is not a valid manifold tet mesh (edges in more than two boundary
    faces, pinched vertices, coincident nodes: 42400-IDGH.stl at the defaults
    gives boundary edges in four faces), it is run once more with half the
    envelope ``epsilon``, which follows the input surface closer and keeps thin
    walls apart; ``info["attempts"]`` says what each run gave.

    Parameters
    ----------
    V : (n, 3) float array
        Surface vertices.
    F : (k, 3) int array
        Surface triangles.
    edge_length : float, optional
        Absolute target edge length; overrides ``edge_length_fac``.
    edge_length_fac : float
        Target edge length as a fraction of the bounding-box diagonal.
    epsilon : float
        Envelope: largest distance of the output surface from the input,
        relative to the bounding-box diagonal.
    optimize : bool
        Let fTetWild improve element quality (slower).
    allow_open : bool
        Accept a surface with border or non-manifold edges (fTetWild fills
        it by winding number); refused by default.
    retry : bool
        Run once more with ``epsilon / 2`` when the output is not a valid mesh.
    log : callable, optional
        ``log(message)`` is told about a retry.
    stage : callable, optional
        ``stage(name)`` is told when each step starts: ``"tetrahedralizing"`` (fTetWild's run, the
        long part; again on a retry) and ``"checking"`` (orienting and validating its output).
        fTetWild reports no progress of its own, so there is no finer measure of how far it is.
    threads : int
        fTetWild's threads (0: every core). fTetWild is not deterministic,
        even on one thread: two runs may differ, and one may need the retry
        when the other does not.

    Returns
    -------
    mesh : Mesh
        The tetrahedral mesh, positively oriented.
    info : dict
        ``{"surface_vertices", "surface_triangles", "flipped_elements", "open_edges",
        "used": {"edge_length", "edge_length_fac", "epsilon", "optimize"}, "retried",
        "attempts": [{"epsilon", "result", "message"}, ...]}``.

    Raises
    ------
    InvalidMeshError
        Bad arrays, an open surface (unless allowed), bad options (``bad_option``; ``out_of_range``
        from :func:`check_edge_length`, naming the field), or a
        tetrahedralization that is not a valid mesh after the retry
        (``tetrahedralization_failed``, with the attempts).
    """
    try:
        V = np.ascontiguousarray(V, dtype=np.float64)
        F = np.ascontiguousarray(F, dtype=np.int64)
    except (TypeError, ValueError) as e:
        raise InvalidMeshError(f"surface arrays are not numeric: {e}", code="bad_shape") from e
    if V.ndim != 2 or V.shape[1] != 3 or V.shape[0] < 4:
        raise InvalidMeshError(f"surface vertices have shape {V.shape}; need (n >= 4, 3)",
                               code="bad_shape")
    if F.ndim != 2 or F.shape[1] != 3 or F.shape[0] < 4:
        raise InvalidMeshError(f"surface triangles have shape {F.shape}; need (k >= 4, 3)",
                               code="bad_shape")
    if not np.isfinite(V).all():
        raise InvalidMeshError("surface has non-finite coordinates", code="non_finite")
    if F.min() < 0 or F.max() >= V.shape[0]:
        raise InvalidMeshError(f"triangle indices span [{F.min()}, {F.max()}] but there are "
                               f"{V.shape[0]} vertices", code="index_out_of_range")
    if not (edge_length is None or edge_length > 0) or not edge_length_fac > 0 or not epsilon > 0:
        raise InvalidMeshError(f"edge_length ({edge_length}), edge_length_fac ({edge_length_fac}) "
                               f"and epsilon ({epsilon}) must be positive", code="bad_option")
    check_edge_length(V, edge_length, edge_length_fac, epsilon)
    opened = open_edges(F)
    if opened.size and not allow_open:
        raise InvalidMeshError(
            f"the surface is not closed: {len(opened)} edges are not shared by exactly two "
            f"triangles (first {opened[:3].tolist()}); close it, or pass allow_open",
            code="open_surface", open_edges=int(len(opened)))
    attempts: list[dict[str, Any]] = []
    tries = (epsilon, epsilon / 2) if retry else (epsilon,)
    mesh, flipped = None, 0
    for k, eps in enumerate(tries):
        if stage is not None:
            stage("tetrahedralizing")
        Vt, Tt = _ftetwild(V, F, edge_length, edge_length_fac, eps, optimize, threads)
        if stage is not None:
            stage("checking")
        try:
            mesh, flipped = _checked(Vt, Tt)
        except InvalidMeshError as e:
            attempts.append({"epsilon": eps, "result": e.code, "message": e.message})
            if k + 1 < len(tries):
                if log is not None:
                    log(f"fTetWild's output at epsilon {eps:g} is not a valid manifold tet mesh ({e.code}: "
                        f"{e.message[:160]}); retrying once with epsilon {tries[k + 1]:g}")
                continue
            raise InvalidMeshError(
                "fTetWild's output is not a valid manifold tet mesh at "
                + " nor at ".join(f"epsilon {a['epsilon']:g} ({a['result']})" for a in attempts)
                + f"; last: {e.message}. Try a smaller edge length (--edge-length-fac) or a smaller epsilon.",
                code="tetrahedralization_failed", attempts=attempts) from e
        attempts.append({"epsilon": eps, "result": "ok", "message": f"{len(mesh.T)} tetrahedra"})
        break
    assert mesh is not None
    used = {"edge_length": edge_length, "edge_length_fac": edge_length_fac, "epsilon": attempts[-1]["epsilon"],
            "optimize": optimize, "threads": threads}
    return mesh, {"surface_vertices": int(len(V)), "surface_triangles": int(len(F)),
                  "flipped_elements": flipped, "open_edges": int(len(opened)), "used": used,
                  "retried": len(attempts) > 1, "attempts": attempts}


def _ftetwild(V: np.ndarray, F: np.ndarray, edge_length: float | None, edge_length_fac: float, epsilon: float,
              optimize: bool, threads: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """One fTetWild run: its points and tets."""
    import pytetwild  # heavy; only needed here

    stray = os.path.join(os.getcwd(), TRACKED_SURFACE)
    had_stray = os.path.exists(stray)
    try:
        Vt, Tt = pytetwild.tetrahedralize(V, F.astype(np.int32), edge_length_fac=edge_length_fac,
                                          edge_length_abs=edge_length, epsilon=epsilon,
                                          optimize=optimize, num_threads=max(int(threads), 0), quiet=True)
    except Exception as e:  # the C++ side reports failures as RuntimeError
        raise InvalidMeshError(f"fTetWild failed: {e}", code="tetrahedralization_failed") from e
    finally:
        if not had_stray and os.path.exists(stray):
            os.unlink(stray)  # fTetWild leaves its tracked surface in the working directory
    return np.asarray(Vt, dtype=np.float64), np.asarray(Tt, dtype=np.int64)


def _checked(Vt: np.ndarray, Tt: np.ndarray) -> tuple[Mesh, int]:
    """Orient, compact and validate fTetWild's output; also return how many tets were flipped."""
    if Tt.size == 0:
        raise InvalidMeshError("fTetWild produced no tetrahedra", code="tetrahedralization_failed")
    vol = signed_volumes(Vt, Tt)
    neg = vol < 0
    Tt = Tt.copy()
    Tt[neg] = Tt[neg][:, [0, 2, 1, 3]]
    used = unique(Tt)
    remap = np.full(len(Vt), -1, np.int64)
    remap[used] = np.arange(used.size)
    return mesh_from_arrays(Vt[used], remap[Tt]), int(neg.sum())
