"""Bounds on the numbers tetmorph accepts, shared by the library's readers and parsers and the service's schema.

A bound lives here once; the service's OpenAPI schema (``service/models/numbers.py``)
and the library's checks read it from here.
"""

from __future__ import annotations

__all__ = ["COORD_MAX"]

#: Largest magnitude of a mesh coordinate, and of any coordinate, direction or target in a
#: document. Far beyond any part in any unit, and small enough that squared distances and
#: cross products of coordinates stay finite in double precision (1e15 squared is 1e30).
COORD_MAX = 1e15
