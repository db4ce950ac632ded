"""Rotations given as quaternion logarithms."""

from __future__ import annotations

import numpy as np

__all__ = ["rotate_by_log"]


def rotate_by_log(v: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Rotate each vector ``v_i`` about ``r_i / |r_i|`` by ``2 |r_i|``.

    Parameters
    ----------
    v : (k, 3) float array
        Vectors (the mean curvature normals ``delta_i``).
    r : (k, 3) float array
        Quaternion logarithms ``r_i = (theta_i / 2) a_i`` (eq. 3.5-3.8 and ECLS eq. 24).

    Returns
    -------
    (k, 3) float array
        ``R_i v_i`` by Rodrigues' formula; ``v_i`` itself where ``r_i = 0``.

    Examples
    --------
    >>> rotate_by_log(np.array([[1., 0, 0]]), np.array([[0, 0, np.pi / 4]])).round(12).tolist()
    [[0.0, 1.0, 0.0]]
    """
    half = np.linalg.norm(r, axis=1)
    theta = 2.0 * half
    a = np.zeros_like(r)
    nz = half > 0
    a[nz] = r[nz] / half[nz, None]
    c = np.cos(theta)[:, None]
    s = np.sin(theta)[:, None]
    adv = np.einsum("ij,ij->i", a, v)[:, None]
    return v * c + np.cross(a, v) * s + a * adv * (1.0 - c)
