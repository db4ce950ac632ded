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

from typing import TYPE_CHECKING, Any

from . import environment  # noqa: F401, I001 - first: spin settings before OpenMP, MKL and OpenBLAS load
from .constraints import ResolvedMove, ResolvedSpec, parse_move, parse_spec
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
from .mesh import Mesh, mesh_from_arrays
from .options import SolveOptions

__all__ = [
    "Deformer", "DeformResult", "precompute", "Mesh", "mesh_from_arrays", "mesh_from_meshio",
    "read_mesh", "write_mesh", "Move", "Spec", "ResolvedMove", "ResolvedSpec", "parse_move", "parse_spec",
    "SolverError",
    "InvalidMeshError", "UnsupportedElementError", "SpecError", "ConstraintError",
    "FactorizationError", "InversionError", "load_kernels", "SolveOptions",
    "Criteria", "preset", "QualityCheck", "quality_check", "deck_element_ids", "element_set",
]
__version__ = "0.1.0"


#: Names loaded on first use: the file formats (meshio among them) when a file is read or written, the
#: document models ``Spec`` and ``Move`` (pydantic's; :func:`parse_spec` and :func:`parse_move` give the
#: resolved :class:`ResolvedSpec` and :class:`ResolvedMove`), ``load_kernels`` (``python -m
#: solver.kernels`` runs that module as the main one), and the quality check.
_ON_FIRST_USE = {"read_mesh": ".io", "write_mesh": ".io", "mesh_from_meshio": ".io", "load_kernels": ".kernels",
                 "Spec": ".documents.spec", "Move": ".documents.move",
                 "Criteria": ".validity.criteria", "preset": ".validity.criteria",
                 "QualityCheck": ".validity.criteria", "quality_check": ".validity.criteria",
                 "deck_element_ids": ".io.element_sets", "element_set": ".io.element_sets"}


def __getattr__(name: str) -> Any:
    """The names of :data:`_ON_FIRST_USE`, imported when first asked for."""
    if name in _ON_FIRST_USE:
        import importlib

        return getattr(importlib.import_module(_ON_FIRST_USE[name], __name__), name)
    raise AttributeError(f"module 'solver' has no attribute {name!r}")


if TYPE_CHECKING:
    from .documents.move import Move
    from .documents.spec import Spec
    from .io import mesh_from_meshio, read_mesh, write_mesh
    from .io.element_sets import deck_element_ids, element_set
    from .kernels import load_kernels
    from .validity.criteria import Criteria, QualityCheck, preset, quality_check
