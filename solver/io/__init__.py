"""Files: reading, writing back in place, converting, tetrahedralizing.

Reading raises typed errors naming what is wrong; writing patches the original
file in place where a patcher is registered, and converts to other formats with
what each can hold; closed surfaces are tetrahedralized with fTetWild.
"""

from . import own_formats  # noqa: F401  (the format modules register themselves)
from .conversion import Loss
from .formats import detect_format, format_of
from .patchers import PATCHERS, Patcher, patcher_for
from .read import mesh_from_meshio, read_mesh
from .write import Written, tet_cell_data, write_mesh

__all__ = ["read_mesh", "mesh_from_meshio", "write_mesh", "Written", "Loss", "tet_cell_data", "PATCHERS",
           "Patcher", "patcher_for", "format_of", "detect_format"]
