"""The service's state, composed: the rooms the routes call.

:class:`Registry` builds the persistent :class:`~service.state.store.Store`
and the worker threads (:class:`~service.state.builder.Builder`) once, and
hands them to three rooms, each with one job:

- ``registry.catalogue``, a :class:`~service.state.catalogue.Catalogue`: the
  stored meshes (upload, parse, cache, list, delete);
- ``registry.sessions``, a :class:`~service.state.sessions.Sessions`: the
  sessions' lifecycle, their builds and the factorization cache, and their
  copies across replicas;
- ``registry.moves``, a :class:`~service.state.moves.MovePath`: a MOVE solved,
  checked and committed.

Only what spans rooms lives here: deleting a mesh asks the sessions whether
one still uses it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..settings import Settings
from .builder import Builder
from .catalogue import Catalogue
from .factor_cache import FactorCache
from .moves import MovePath
from .parse_pool import ParseLimits, shared_pool
from .sessions import Sessions
from .store import Store
from .stores import open_store

__all__ = ["Registry"]


class Registry:
    """Meshes, sessions and MOVEs of one service instance.

    Parameters
    ----------
    settings : Settings
    store : Store, optional
        Default: :func:`~service.state.stores.open_store` of the settings.
    """

    def __init__(self, settings: Settings, store: Store | None = None) -> None:
        self.settings = settings
        self.store: Store = store if store is not None else open_store(
            settings.data_dir, settings.database_url, settings.read_bounds(), settings.min_free_bytes)
        self.factors = FactorCache(settings.cache_budget_bytes)
        self.builder = Builder(settings.build_workers, settings.solve_pool_size, settings.solve_options())
        self.parse = shared_pool(settings.parse_workers, ParseLimits(settings.parse_time_limit_s,
                                                                     settings.parse_cpu_limit_s,
                                                                     settings.parse_memory_bytes),
                                 settings.parse_queue_depth)
        self.catalogue = Catalogue(self.store, self.builder, settings.max_elements, self.parse)
        self.sessions = Sessions(settings, self.store, self.builder, self.factors, self.catalogue)
        self.moves = MovePath(self.sessions, self.store, self.builder)

    def start(self) -> None:
        """Start the worker threads (again, after :meth:`close`)."""
        if self.builder.closed:
            self.builder.start()
        self.parse.start()

    def close(self) -> None:
        """Stop the worker threads."""
        self.builder.close()

    def close_store(self) -> None:
        """Release the store's connections."""
        self.store.close()

    async def run(self, fn: Callable[..., Any], *args: Any) -> Any:
        """Run a blocking call (file export, packing) in a worker thread."""
        return await self.builder.run(fn, *args)

    @property
    def evictions(self) -> int:
        """Sessions evicted from the factorization cache so far."""
        return self.factors.evictions

    @property
    def cached_sessions(self) -> int:
        """Sessions whose factorizations are in the cache."""
        return len(self.factors)

    @property
    def cache_bytes(self) -> int:
        """Bytes held by cached factorizations."""
        return self.factors.total

    def delete_mesh(self, owner: str, mesh_id: str) -> None:
        """Delete a mesh; 409 ``mesh_in_use`` while a session uses it (as its mesh or a target surface)."""
        self.catalogue.meta(owner, mesh_id)
        self.catalogue.delete(owner, mesh_id, self.sessions.users_of_mesh(mesh_id))
