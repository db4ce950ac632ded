"""Pictures of real morphs for the site, rendered when it is built (matplotlib, off-screen).

* :func:`bracket_displacement_png` -- the first tutorial's morph of ``tests/data/ccx_bracket.inp``
  (its SPEC and MOVE), the rest shape beside the morphed one coloured by displacement.

Run it alone to write the PNG: ``python docs/scripts/pictures.py out.png``.
"""

from __future__ import annotations

import io
import sys
from pathlib import Path

import numpy as np

__all__ = ["displacement_png", "bracket_displacement_png"]

ROOT = Path(__file__).resolve().parents[2]
#: The first tutorial's SPEC and MOVE (docs/tutorials/morph-a-deck.md, steps 2 and 3).
BRACKET_SPEC = {"selections": {"clamp": {"set": "FIXED"}, "tip": {"set": "LOAD"}, "bore": {"set": "HOLE"}},
                "fixed": ["clamp", "tip"], "handles": {"bore": "bore"}}
BRACKET_MOVE = {"handles": {"bore": {"translation": [-4.0, 0.0, 0.0]}}}


def displacement_png(V0: np.ndarray, V: np.ndarray, F: np.ndarray, title: str, units: str = "mm") -> bytes:
    """The boundary faces ``F`` at rest (grey) and moved (coloured by displacement), side by side.

    Parameters
    ----------
    V0, V : (n, 3) float arrays
        Rest and morphed positions.
    F : (k, 3) int array
        Boundary triangles.
    title : str
        Title of the morphed view.
    units : str
        Units of the colour bar.

    Returns
    -------
    bytes
        A PNG without a creation date or software tag.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    moved = np.linalg.norm(V - V0, axis=1)
    norm, cmap = plt.Normalize(0.0, float(moved.max()) or 1.0), plt.get_cmap("viridis")
    sun = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    lo, hi = V0.min(0), V0.max(0)
    fig = plt.figure(figsize=(12, 3.6))
    for k, (P, name, colour) in enumerate(((V0, "rest", None), (V, title, moved[F].mean(axis=1)))):
        ax = fig.add_subplot(1, 2, k + 1, projection="3d")
        n = np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]])
        n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-300
        shade = 0.55 + 0.45 * np.clip(n @ sun, 0.0, 1.0)
        base = np.tile([0.75, 0.75, 0.78], (len(F), 1)) if colour is None else cmap(norm(colour))[:, :3]
        ax.add_collection3d(Poly3DCollection(P[F], facecolors=base * shade[:, None], edgecolors="none"))
        ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), zlim=(lo[2], hi[2]))
        ax.set_title(name, y=0.9)
        ax.set_box_aspect(hi - lo, zoom=1.2)
        ax.set_axis_off()
        ax.view_init(elev=38, azim=-75)
    fig.subplots_adjust(left=0, right=0.93, wspace=0)
    fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=fig.axes[1], shrink=0.6,
                 label=f"displacement {units}")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


def bracket_displacement_png() -> bytes:
    """The first tutorial's morph: the bore of the CalculiX bracket moved 4 mm toward the clamp."""
    from solver import precompute, read_mesh

    mesh = read_mesh(ROOT / "tests" / "data" / "ccx_bracket.inp")
    result = precompute(mesh, BRACKET_SPEC).solve(BRACKET_MOVE)
    return displacement_png(mesh.V, result.V, mesh.F, "bore moved 4 mm toward the clamp")


if __name__ == "__main__":
    Path(sys.argv[1]).write_bytes(bracket_displacement_png())
