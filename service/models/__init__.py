"""pydantic models of what the service accepts and answers (they make ``/openapi.json``).

The documents the library reads and writes (SPEC, MOVE, SHAPES, REPORT) are defined once, in
:mod:`solver.documents`; the modules here add what only the service has.

* :mod:`~service.models.error` -- the error envelope;
* :mod:`~service.models.mesh` -- mesh documents;
* :mod:`~service.models.session` -- session documents and presets (named MOVEs);
* :mod:`~service.models.spec`, :mod:`~service.models.move` -- the service's checks of a SPEC against
  the stored mesh, and the stream frame that carries a MOVE;
* :mod:`~service.models.service` -- health, readiness, formats, jobs.
"""
