"""Files: reading with meshio, writing back in place where a patcher is registered, tetrahedralizing."""

from .patchers import PATCHERS, Patcher, patcher_for
from .read import mesh_from_meshio, read_mesh
from .write import tet_cell_data, write_mesh

__all__ = ["read_mesh", "mesh_from_meshio", "write_mesh", "tet_cell_data", "PATCHERS", "Patcher", "patcher_for"]
