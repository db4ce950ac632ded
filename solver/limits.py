"""Bounds on the numbers tetmorph accepts, shared by the library's readers and parsers and the service's schema.

A bound lives here once; the service's OpenAPI schema (``service/models/numbers.py``)
and the library's checks read it from here.
"""

from __future__ import annotations

__all__ = ["COORD_MAX", "MAX_POINTS", "MAX_CELLS"]

#: Largest magnitude of a mesh coordinate, and of any coordinate, direction or target in a
#: document. Far beyond any part in any unit, and small enough that squared distances and
#: cross products of coordinates stay finite in double precision (1e15 squared is 1e30).
COORD_MAX = 1e15
#: Most nodes a mesh file may declare. Readers check the counts a file declares (VTU's
#: ``NumberOfPoints``, legacy VTK's ``POINTS``, Gmsh's ``$Nodes`` header) before anything is
#: decompressed or allocated: a few hundred kilobytes of zlib can declare gigabytes. 50M nodes is
#: about 1.2 GB of coordinates, some 300M linear tets, far beyond a morphing job.
MAX_POINTS = 50_000_000
#: Most elements a mesh file may declare (checked as :data:`MAX_POINTS`).
MAX_CELLS = 300_000_000
