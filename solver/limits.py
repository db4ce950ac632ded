"""Bounds on the numbers tetmorph accepts, shared by the library's readers and parsers and the service's schema.

A bound lives here once; the service's OpenAPI schema (through ``solver/documents/numbers.py``)
and the library's checks read it from here.
"""

from __future__ import annotations

__all__ = ["COORD_MAX", "MAX_POINTS", "MAX_CELLS", "EXTENT", "SCALE_MIN", "SCALE_MAX", "PENALTY_MAX",
           "WALL_WEIGHT_MAX", "POINT_WEIGHT_MAX", "ID_MAX", "ANGLE_MAX", "ANGLE_BETWEEN_MAX",
           "TARGET_AMOUNT_MAX", "SHAPES_MAX", "SHAPE_NAME_MAX", "PLAN_ROWS_MAX", "PLAN_TEXT_MAX", "BLOCK_MAX",
           "SHAPE_VALUE_MAX", "BOUNDS_TOL_MAX", "MAX_EXPANDED_BYTES",
           "THREADS_MAX", "LATTICE_COUNT_MAX", "EDGE_LENGTH_FAC_MIN", "EDGE_LENGTH_FAC_MAX",
           "ENVELOPE_MAX"]

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
#: Translations, offsets and pivots, point targets and motion points: within this many
#: bounding-box diagonals of the mesh (of its centre, for positions). A morph a hundred times
#: the part's size is a unit mistake, not a design.
EXTENT = 100.0
#: Range of uniform scale factors (handles, relative constraints, features).
SCALE_MIN, SCALE_MAX = 1e-3, 1e3
#: Largest penalty weight (SPEC.constraints.penalty_weight): the penalised system's condition
#: number grows as its square (``benchmarks/measure_choices.py --only penalty``).
PENALTY_MAX = 1e8
#: Largest thin-wall weight (SPEC.thin_walls.weight).
WALL_WEIGHT_MAX = 1e6
#: Largest magnitude of a weight of a POINT's vertices (``vertices`` + ``weights``).
POINT_WEIGHT_MAX = 1e6
#: Largest vertex id a document may name before the mesh's own count is checked: meshes hold
#: at most :data:`MAX_POINTS` nodes, far below it.
ID_MAX = 2**31 - 1
#: Largest magnitude of an angle in degrees (rotations, cyclic sectors): ten turns. A rotation
#: is reduced modulo 360 degrees, but at 1e6 degrees and beyond the number holds no meaningful
#: fraction of a turn, and such a value is a mistake to report, not a rotation to make.
ANGLE_MAX = 3600.0
#: Largest angle between two features' directions (MOVE ``angle.NAME.angle_deg``): a measured angle
#: between two lines or normals lies in [0, 180] degrees.
ANGLE_BETWEEN_MAX = 180.0
#: Largest magnitude of a target surface's MOVE ``amount`` (1: on the surface, 0: at rest).
TARGET_AMOUNT_MAX = 10.0
#: Most shapes in one SHAPES document, and so most columns of a PLAN (each column is a shape).
SHAPES_MAX = 1000
#: Longest shape name, which is a PLAN column's header.
SHAPE_NAME_MAX = 200
#: Most rows (variants) of one PLAN.
PLAN_ROWS_MAX = 1_000_000
#: Longest PLAN CSV text, in characters: a million rows of a few shapes.
PLAN_TEXT_MAX = 50_000_000
#: Most PLAN rows in one stacked back-substitution: the right-hand sides of a block are held at once,
#: three columns a row.
BLOCK_MAX = 1024
#: Largest magnitude of a shape's parameter value in a bounds search's range: a shape is a MOVE at
#: value 1, and a million times it is a mistake in the range, not a design.
SHAPE_VALUE_MAX = 1e6
#: Widest final bracket of a bounds search, in parameter units.
BOUNDS_TOL_MAX = 1e3
#: Largest magnitude of a quality-check threshold (:class:`solver.validity.criteria.Criteria`): every
#: measure is a ratio, an angle or a scaled Jacobian, and a threshold must be finite to check anything.
QUALITY_THRESHOLD_MAX = 1e12
#: Most bytes the data arrays of a file may take once read, in all: compressed ones (VTU's zlib or LZMA
#: blocks, HDF5 datasets of XDMF, CGNS, MED) checked from the block headers and dataset shapes before
#: anything is decompressed and again while decompressing, uncompressed tables (legacy VTK, TetGen)
#: from their declared counts. A file at :data:`MAX_POINTS` and
#: :data:`MAX_CELLS` (coordinates, connectivity, offsets and types) holds about 14 GB.
MAX_EXPANDED_BYTES = 16 * 2**30
#: Most threads a SPEC or a caller may ask one solve to use (a cap: a solve never takes more than the
#: cores that are free).
THREADS_MAX = 1024
#: Most control points of a morph volume's lattice along one axis (SPEC ``lattice[].counts``): a
#: Bernstein polynomial of degree 15 at most per axis, 4,096 control points in all.
LATTICE_COUNT_MAX = 16
#: Smallest target edge length of a tetrahedralization, as a fraction of the surface's bounding-box
#: diagonal (``edge_length_fac``, and an absolute ``edge_length`` divided by the diagonal). A tet mesh's
#: count grows as the cube of the inverse: at a thousandth of the diagonal a cube holds some
#: 10^8 tetrahedra, beyond what fTetWild finishes within the service's time limit or memory.
EDGE_LENGTH_FAC_MIN = 1e-3
#: Largest target edge length, as a fraction of the bounding-box diagonal: one edge across the part.
EDGE_LENGTH_FAC_MAX = 1.0
#: Largest fTetWild envelope (``epsilon``), as a fraction of the bounding-box diagonal: a tenth of the
#: part's size is no longer its shape.
ENVELOPE_MAX = 0.1
