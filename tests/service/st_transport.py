"""Send schemathesis cases through one FastAPI TestClient, so the app runs one lifespan for a whole run.

Over ASGI (``schemathesis.openapi.from_asgi`` and ``case.call()``), schemathesis runs the app's
lifespan itself and ends it after each test item: the registry's pools are closed under the next
item (a session build then answers 500). Load the schema with ``from_dict(app.openapi())`` and
send each case with :func:`send`.
"""

from __future__ import annotations

import json
from typing import Any

from fastapi.testclient import TestClient

__all__ = ["send"]


def send(client: TestClient, case: Any) -> Any:
    """Send ``case`` as schemathesis sends it over ASGI; answer the response (with its request read)."""
    kwargs = case.as_transport_kwargs(base_url=str(client.base_url))
    if not kwargs.get("cookies"):
        kwargs.pop("cookies", None)
    if kwargs.get("files"):  # form values other than text go as their JSON text
        kwargs["files"] = [(k, (name, v if isinstance(v, (str, bytes)) else json.dumps(v)))
                           for k, (name, v, *_) in kwargs["files"]]
    response = client.request(**kwargs)
    response.request.read()  # a multipart body is a stream; the checks read what was sent
    return response
