"""Parsed meshes kept in memory, least recently used first out."""

from __future__ import annotations

from collections import OrderedDict

from solver.mesh import Mesh

__all__ = ["MeshCache"]


class MeshCache:
    """An LRU of parsed meshes by id.

    Parameters
    ----------
    capacity : int
        How many meshes stay (meshes held by sessions' deformers are not counted).
    """

    def __init__(self, capacity: int = 16) -> None:
        self.capacity = capacity
        self._meshes: OrderedDict[str, Mesh] = OrderedDict()

    def get(self, mesh_id: str) -> Mesh | None:
        """The cached mesh (marked as used), or None."""
        m = self._meshes.get(mesh_id)
        if m is not None:
            self._meshes.move_to_end(mesh_id)
        return m

    def put(self, mesh_id: str, mesh: Mesh) -> None:
        """Cache a mesh, dropping the least recently used beyond the capacity."""
        self._meshes[mesh_id] = mesh
        self._meshes.move_to_end(mesh_id)
        while len(self._meshes) > self.capacity:
            self._meshes.popitem(last=False)

    def drop(self, mesh_id: str) -> None:
        """Forget a mesh."""
        self._meshes.pop(mesh_id, None)

    def __len__(self) -> int:
        return len(self._meshes)
