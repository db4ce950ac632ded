"""The stored meshes of one service instance: upload, parse, cache, list and delete.

:class:`Catalogue` owns the meshes' side of the persistent
:class:`~service.state.store.Store` and the in-memory
:class:`~service.state.mesh_cache.MeshCache` of parsed meshes. Parsing runs in
worker processes (:mod:`service.state.parse_pool`): neither the event loop nor
any thread of the server reads an uploaded file. A mesh is
stored whole or not at all: a file that does not parse, or a mesh over the
service's element limit, leaves nothing behind.

Which sessions use a mesh is the sessions' business, not the catalogue's:
:meth:`Catalogue.delete` is told by its caller.
"""

from __future__ import annotations

import time
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

from solver.mesh import Mesh

from ..errors import NotFound, ServiceError
from .builder import Builder
from .mesh_cache import MeshCache
from .parse_pool import ParsePool
from .store import Store, new_id

__all__ = ["Catalogue"]


class Catalogue:
    """Meshes kept by a store, parsed on demand and cached.

    Parameters
    ----------
    store : Store
    builder : Builder
        Whose worker threads summarise the meshes.
    max_elements : int
        The most volume elements a stored mesh may have (422 ``too_many_elements`` beyond).
    parse : ParsePool, optional
        The worker processes that read the stored files (default: the builder's threads).
    """

    def __init__(self, store: Store, builder: Builder, max_elements: int, parse: ParsePool | None = None) -> None:
        self.store = store
        self.builder = builder
        self.max_elements = max_elements
        self.parse = parse
        self.cache = MeshCache()

    async def _load(self, meta: dict[str, Any]) -> Mesh:
        """Read a stored mesh's files in a parse worker (arrays stored by the service itself: here)."""
        if self.parse is None or meta.get("format") == "arrays":
            return await self.builder.run(self.store.load_mesh, meta)
        return await self.parse.call(str(meta.get("owner", "")), "service.state.reads.read_stored",
                                     str(self.store.root), meta, self.store.bounds,
                                     what=repr(str(meta.get("file", "the file"))))

    def meta(self, owner: str, mesh_id: str) -> dict[str, Any]:
        """Meta of a mesh owned by ``owner``; 404 otherwise (also for other keys' meshes)."""
        meta = self.store.mesh_meta(mesh_id)
        if meta is None or meta.get("owner") != owner:
            raise NotFound("mesh", mesh_id)
        return meta

    def owned(self, owner: str) -> list[dict[str, Any]]:
        """Metas of the meshes of ``owner``, oldest first."""
        return [m for m in self.store.list_meshes() if m.get("owner") == owner]

    async def mesh(self, meta: dict[str, Any]) -> Mesh:
        """The parsed mesh of a stored meta (read in a worker thread on a miss)."""
        m = self.cache.get(meta["id"])
        if m is None:
            m = await self._load(meta)
            self.cache.put(meta["id"], m)
        return m

    def file(self, meta: dict[str, Any]) -> Path:
        """Path of the stored main file."""
        return self.store.mesh_dir(meta["id"]) / meta["file"]

    def check_size(self, mesh: Mesh) -> None:
        """422 ``too_many_elements`` when ``mesh`` is over the service's limit."""
        m = mesh.elements
        if m > self.max_elements:
            raise ServiceError("too_many_elements", f"the mesh has {m} volume elements; this service "
                               f"accepts at most {self.max_elements}", elements=m, limit=self.max_elements)

    async def add(self, owner: str, name: str, fmt: str, files: dict[str, bytes],
                  main: str, mesh_id: str | None = None) -> dict[str, Any]:
        """Store uploaded file(s) and parse them.

        Parameters
        ----------
        owner, name : str
        fmt : str
            meshio format name.
        files : dict of str to bytes
            File name (sanitized) to content; ``main`` is the one to read
            (TetGen's ``.node`` next to its ``.ele``). A name may hold folders
            (``include/nodes.inp``, a file a deck includes): it is stored under
            them in the mesh's folder, and read from there after a restart.
        main : str
        mesh_id : str, optional
            A fixed id (the demo); random by default.

        Returns
        -------
        dict
            The mesh meta (id, counts, element types, sets, quality under ``info``).
        """
        mid = mesh_id or new_id("m")
        meta = {"id": mid, "owner": owner, "name": name, "format": fmt, "file": main,
                "files": sorted(files), "created": time.time()}

        async def write_and_read(d: Path) -> tuple[Mesh, dict[str, Any] | None]:
            root = d.resolve()
            for fname, data in files.items():
                target = (d / fname).resolve()
                if root not in target.parents:  # names are cleaned by the route: never outside the folder
                    raise ServiceError("invalid_request", f"file name {fname!r} leaves the mesh's folder",
                                       field="companions")
                target.parent.mkdir(parents=True, exist_ok=True)
                target.write_bytes(data)
            if self.parse is None:
                return await self._load(meta), None
            # read, held to what a mesh to morph is and summarised in a worker: the server gets the result
            return await self.parse.call(owner, "service.state.reads.read_upload", str(self.store.root), meta,
                                         self.store.bounds, what=repr(name))

        return await self._store(meta, write_and_read)

    async def add_arrays(self, owner: str, name: str, mesh: Mesh,
                         extra: dict[str, Any] | None = None) -> dict[str, Any]:
        """Store a mesh built from arrays (JSON upload, tetrahedralization)."""
        self.check_size(mesh)  # before anything is written
        meta = {"id": new_id("m"), "owner": owner, "name": name, "format": "arrays",
                "file": "arrays.npz", "files": ["arrays.npz"], "created": time.time(),
                **(extra or {})}

        async def write(d: Path) -> tuple[Mesh, dict[str, Any] | None]:
            self.store.save_arrays(meta["id"], mesh)
            return mesh, None

        return await self._store(meta, write)

    async def _store(self, meta: dict[str, Any],
                     produce: Callable[[Path], Awaitable[tuple[Mesh, dict[str, Any] | None]]]) -> dict[str, Any]:
        """Create the mesh's directory and let ``produce`` fill it and return the parsed mesh (and its summary).

        Then check its size and save ``meta`` with its summary; remove everything on failure.
        """
        mid = meta["id"]
        d = self.store.new_mesh_dir(mid)
        try:
            mesh, info = await produce(d)
            self.check_size(mesh)
            meta["info"] = info if info is not None else await self.builder.solve(mesh.info)
            self.store.save_mesh_meta(meta)
        except BaseException:
            self.store.delete_mesh(mid)
            raise
        self.cache.put(mid, mesh)
        return meta

    def delete(self, owner: str, mesh_id: str, users: list[str]) -> None:
        """Delete a mesh of ``owner``; 409 ``mesh_in_use`` when ``users`` (session ids) is not empty."""
        self.meta(owner, mesh_id)
        if users:
            raise ServiceError("mesh_in_use", f"mesh {mesh_id} is used by sessions {users}; delete "
                               "them first", sessions=users)
        self.cache.drop(mesh_id)
        self.store.delete_mesh(mesh_id)
