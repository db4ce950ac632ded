"""What each mesh format keeps, measured by ``python -m service.formats`` (do not edit)."""

TABLE = {
 "meshio": "5.3.5",
 "formats": [
  {
   "name": "abaqus",
   "extension": ".inp",
   "needs": None,
   "read": True,
   "write": True,
   "sets": True,
   "quadratic": True,
   "mixed": False
  },
  {
   "name": "gmsh",
   "extension": ".msh",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": True,
   "mixed": True
  },
  {
   "name": "gmsh22",
   "extension": ".msh",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": True,
   "mixed": True
  },
  {
   "name": "vtu",
   "extension": ".vtu",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": True,
   "mixed": True
  },
  {
   "name": "vtk",
   "extension": ".vtk",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": True,
   "mixed": True
  },
  {
   "name": "medit",
   "extension": ".mesh",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": False,
   "mixed": True
  },
  {
   "name": "tetgen",
   "extension": ".node",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": False,
   "mixed": False
  },
  {
   "name": "nastran",
   "extension": ".bdf",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": True,
   "mixed": True
  },
  {
   "name": "xdmf",
   "extension": ".xdmf",
   "needs": "h5py",
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": True,
   "mixed": True
  },
  {
   "name": "ansys",
   "extension": ".msh",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": False,
   "mixed": True
  },
  {
   "name": "avsucd",
   "extension": ".avs",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": False,
   "mixed": True
  },
  {
   "name": "dolfin-xml",
   "extension": ".xml",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": False,
   "mixed": False
  },
  {
   "name": "exodus",
   "extension": ".e",
   "needs": "netCDF4",
   "read": True,
   "write": True,
   "sets": True,
   "quadratic": True,
   "mixed": True
  },
  {
   "name": "flac3d",
   "extension": ".f3grid",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": False,
   "mixed": True
  },
  {
   "name": "mdpa",
   "extension": ".mdpa",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": True,
   "mixed": False
  },
  {
   "name": "med",
   "extension": ".med",
   "needs": "h5py",
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": True,
   "mixed": True
  },
  {
   "name": "netgen",
   "extension": ".vol",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": True,
   "mixed": True
  },
  {
   "name": "permas",
   "extension": ".dato",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": False,
   "mixed": True
  },
  {
   "name": "su2",
   "extension": ".su2",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": False,
   "mixed": True
  },
  {
   "name": "ugrid",
   "extension": ".ugrid",
   "needs": None,
   "read": False,
   "write": False,
   "sets": False,
   "quadratic": False,
   "mixed": False
  },
  {
   "name": "cgns",
   "extension": ".cgns",
   "needs": "h5py",
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": False,
   "mixed": False
  },
  {
   "name": "h5m",
   "extension": ".h5m",
   "needs": "h5py",
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": False,
   "mixed": False
  },
  {
   "name": "hmf",
   "extension": ".hmf",
   "needs": "h5py",
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": True,
   "mixed": True
  },
  {
   "name": "tecplot",
   "extension": ".dat",
   "needs": None,
   "read": True,
   "write": True,
   "sets": False,
   "quadratic": False,
   "mixed": False
  }
 ]
}
