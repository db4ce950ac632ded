"""The mesh: the :class:`Mesh` dataclass, its validation and derived topology."""

from .mesh import IGNORED_TYPES, MIXED_TYPES, VOLUME_TYPES, Mesh, mesh_from_arrays
from .validate import validate

__all__ = ["Mesh", "mesh_from_arrays", "validate", "IGNORED_TYPES", "MIXED_TYPES", "VOLUME_TYPES"]
