"""Rotations given as quaternion logarithms (the batch rotation: a compiled kernel in src/core/geometry.cpp)."""

from __future__ import annotations

import numpy as np
import tetmorph_core

__all__ = ["rotate_by_log", "log_to_matrix"]


def rotate_by_log(v: np.ndarray, r: np.ndarray, scale: np.ndarray | None = None) -> np.ndarray:
    """Rotate each vector ``v_i`` about ``r_i / |r_i|`` by ``2 |r_i|`` (and scale it by ``scale_i``).

    Parameters
    ----------
    v : (k, 3) float array
        Vectors (the mean curvature normals ``delta_i``).
    r : (k, 3) float array
        Quaternion logarithms ``r_i = (theta_i / 2) a_i`` (eq. 3.5-3.8 and ECLS eq. 24).
    scale : (k,) float array, optional
        Factors applied in the same pass (the scale field ``s_i`` of eq. 3.2).

    Returns
    -------
    (k, 3) float array
        ``s_i R_i v_i`` by Rodrigues' formula; ``s_i v_i`` where ``r_i = 0``.

    Examples
    --------
    >>> rotate_by_log(np.array([[1., 0, 0]]), np.array([[0, 0, np.pi / 4]])).round(12).tolist()
    [[0.0, 1.0, 0.0]]
    """
    v = np.ascontiguousarray(v, dtype=np.float64)
    r = np.ascontiguousarray(r, dtype=np.float64)
    out = np.empty_like(v)
    if len(v):
        ones = scale is None
        f = np.ones(1) if ones else np.ascontiguousarray(scale, dtype=np.float64)
        if not ones and f.shape != (len(v),):
            raise ValueError(f"rotate_by_log: scale {f.shape} does not match {len(v)} vectors")
        tetmorph_core.geometry_rotate_by_log(v, r, f, ones, out)
    return out


def log_to_matrix(r: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) of one quaternion logarithm ``r`` (3,): about ``r/|r|`` by ``2|r|``.

    Examples
    --------
    >>> (log_to_matrix(np.array([0, 0, np.pi / 4])) @ [1.0, 0, 0]).round(12).tolist()
    [0.0, 1.0, 0.0]
    """
    half = float(np.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]))
    if half == 0.0:
        return np.eye(3)
    x, y, z = (float(c) / half for c in r)
    th = 2.0 * half
    c, s = np.cos(th), np.sin(th)
    C = 1.0 - c
    return np.array([[c + x * x * C, x * y * C - z * s, x * z * C + y * s],
                     [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
                     [z * x * C - y * s, z * y * C + x * s, c + z * z * C]])
