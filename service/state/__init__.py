"""In-memory and on-disk state of the service.

* :mod:`~service.state.session` -- one session (:class:`Session`) and its :class:`SessionStatus`;
* :mod:`~service.state.store` -- persistence of meshes and session records in the data directory;
* :mod:`~service.state.mesh_cache` -- parsed meshes kept in memory (LRU by count);
* :mod:`~service.state.factor_cache` -- sessions holding factorizations (LRU by bytes);
* :mod:`~service.state.builder` -- worker threads, session builds and solves;
* :mod:`~service.state.sweeper` -- removal of idle sessions;
* :mod:`~service.state.registry` -- the facade the routes use.
"""
