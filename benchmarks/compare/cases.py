"""The selections shared by the study scripts: slabs along a mesh's longest axis."""

from __future__ import annotations

import numpy as np


def slab_spec(mesh) -> tuple[dict, int, float]:
    """SPEC fixing the lowest 10% along the longest axis, the highest 10% the handle ``h``.

    Returns
    -------
    spec : dict
    ax : int
        The longest axis.
    diag : float
        The bounding-box diagonal of the used vertices.
    """
    V = mesh.V[mesh.referenced]
    lo, hi = V.min(0), V.max(0)
    ax = int(np.argmax(hi - lo))
    L, diag = hi[ax] - lo[ax], float(np.linalg.norm(hi - lo))

    def box(a: float, b: float) -> dict:
        mn, mx = lo - 1e-9 * L, hi + 1e-9 * L
        mn[ax], mx[ax] = lo[ax] + a * L - 1e-9 * L, lo[ax] + b * L + 1e-9 * L
        return {"box": {"min": mn.tolist(), "max": mx.tolist()}}

    spec = {"selections": {"fix": box(0, 0.1), "hand": box(0.9, 1.0)}, "fixed": ["fix"], "handles": {"h": "hand"}}
    return spec, ax, diag
