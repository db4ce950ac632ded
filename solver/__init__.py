"""tetmorph solver: volumetric deformation of tetrahedral FE meshes.

Pure numerics (numpy, scipy, meshio and a sparse direct backend); no web code.

Examples
--------
>>> from solver import mesh_from_arrays, precompute
>>> from solver.testing import cube_mesh
>>> mesh = mesh_from_arrays(*cube_mesh(2))
>>> d = precompute(mesh, {"selections": {"a": {"box": {"min": [0, 0, 0], "max": [1, 1, 0]}},
...                                      "b": {"box": {"min": [0, 0, 1], "max": [1, 1, 1]}}},
...                       "fixed": ["a"], "handles": {"b": "b"}})
>>> d.solve({"handles": {"b": {"translation": [0, 0, 0.1]}}}).report["inverted_elements"]
0
"""

from . import environment  # noqa: F401, I001 - first: spin settings before numba, MKL and OpenBLAS load
from .constraints import Move, Spec, parse_move, parse_spec
from .deform import Deformer, DeformResult, precompute
from .errors import (
    ConstraintError,
    FactorizationError,
    InvalidMeshError,
    InversionError,
    SolverError,
    SpecError,
    UnsupportedElementError,
)
from .io import mesh_from_meshio, read_mesh, write_mesh
from .kernels import load_kernels
from .mesh import Mesh, mesh_from_arrays
from .options import SolveOptions

__all__ = [
    "Deformer", "DeformResult", "precompute", "Mesh", "mesh_from_arrays", "mesh_from_meshio",
    "read_mesh", "write_mesh", "Move", "Spec", "parse_move", "parse_spec", "SolverError",
    "InvalidMeshError", "UnsupportedElementError", "SpecError", "ConstraintError",
    "FactorizationError", "InversionError", "load_kernels", "SolveOptions",
]
__version__ = "0.1.0"
