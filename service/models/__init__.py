"""pydantic models of what the service accepts and answers (they make ``/openapi.json``).

* :mod:`~service.models.error` -- the error envelope;
* :mod:`~service.models.mesh` -- mesh documents;
* :mod:`~service.models.report` -- the REPORT of an update;
* :mod:`~service.models.session` -- session documents;
* :mod:`~service.models.spec`, :mod:`~service.models.move` -- the SPEC and MOVE documents;
* :mod:`~service.models.service` -- health, readiness, formats, jobs.
"""
