"""The format modules that register themselves in :mod:`solver.io.registry` (imported for that effect).

Each format's sniffer is asked at its own place (:attr:`~solver.io.registry.FileFormat.sniff_order`);
formats of the same place are asked in the order they are imported here.
"""

from . import abaqus_deck  # noqa: F401  Abaqus/CalculiX, assemblies and includes
from .cdb import CDB  # noqa: F401  Ansys MAPDL .cdb
from .gmsh_format import GMSH  # noqa: F401  Gmsh .msh
from .lsdyna import LSDYNA  # noqa: F401  LS-DYNA keyword
from .medit_format import MEDIT  # noqa: F401  Medit .mesh / .meshb
from .nastran_format import NASTRAN  # noqa: F401  Nastran bulk data
from .tetgen_format import TETGEN  # noqa: F401  TetGen .node + .ele
from .vtk_format import VTK  # noqa: F401  legacy VTK
from .vtu_format import VTU  # noqa: F401  VTK XML unstructured grid
