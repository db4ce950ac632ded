"""The format modules that register themselves in :mod:`solver.io.registry` (imported for that effect)."""

from . import abaqus_deck  # noqa: F401  Abaqus/CalculiX, assemblies and includes
from .cdb import CDB  # noqa: F401  Ansys MAPDL .cdb
from .lsdyna import LSDYNA  # noqa: F401  LS-DYNA keyword
