"""Print the basic positions pyNastran reads from a Nastran deck, as JSON ``{grid: [x, y, z]}``.

Run by tests/solver/io/test_nastran_coords.py with the interpreter of ``.venv-nastran`` (made by
``make test``): pyNastran 1.4.1 pins numpy < 2, so it lives in a virtualenv of its own.

Usage: ``python pynastran_positions.py DECK [punch]``
"""

import json
import sys


def main() -> None:
    """Read the deck named on the command line and print its grids' basic positions."""
    from pyNastran.bdf.bdf import BDF

    model = BDF(debug=None)
    model.read_bdf(sys.argv[1], xref=True, punch=len(sys.argv) > 2 and sys.argv[2] == "punch")
    json.dump({int(nid): [float(v) for v in node.get_position()] for nid, node in model.nodes.items()},
              sys.stdout)


if __name__ == "__main__":
    main()
