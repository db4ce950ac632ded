"""In-memory and on-disk state of the service.

* :mod:`~service.state.registry` -- composes the rooms below; what the routes are given;
* :mod:`~service.state.catalogue` -- the stored meshes (:class:`Catalogue`);
* :mod:`~service.state.sessions` -- the sessions' lifecycle, builds and replica copies (:class:`Sessions`);
* :mod:`~service.state.moves` -- a MOVE solved, checked and committed (:class:`MovePath`);
* :mod:`~service.state.surfaces` -- a SPEC's stored target surfaces resolved;
* :mod:`~service.state.session` -- one session (:class:`Session`) and its :class:`SessionStatus`;
* :mod:`~service.state.store` -- persistence of meshes and session records in the data directory;
* :mod:`~service.state.mesh_cache` -- parsed meshes kept in memory (LRU by count);
* :mod:`~service.state.factor_cache` -- sessions holding factorizations (LRU by bytes);
* :mod:`~service.state.builder` -- worker threads, session builds and solves;
* :mod:`~service.state.memory` -- freed memory handed back to the system;
* :mod:`~service.state.sweeper` -- removal of idle sessions.
"""
