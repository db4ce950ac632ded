"""TetGen meshes (``.node`` + ``.ele``): the format's entry in the registry, its sniffer and size check.

:func:`solver.io.tetgen.read_tetgen` reads the pair (named by either file) in
the file's own numbering; :func:`solver.io.patch_node.patch_node` writes the
``.node`` back with new coordinates, the ``.ele`` kept byte for byte. Before
reading, the counts the two headers declare (and the numbers each line holds)
are held to the read bounds.
"""

from __future__ import annotations

import os
import re
import warnings
from typing import Any

from .diagnose import check_last_line
from .patch_node import node_count, patch_node
from .patchers import Patcher
from .read_bounds import ReadBounds, check_bounds, check_holds
from .registry import FileFormat, register_format
from .tetgen import read_tetgen, tetgen_paths

__all__ = ["TETGEN", "sniff", "check_sizes"]

_HEAD = re.compile(rb"^\s*\d+\s+3\s+\d+\s+\d+\s*$")


def sniff(head: bytes, size: int | None = None) -> bool:
    r"""Whether a file's first data line is a ``.node`` header: ``<points> 3 <attributes> <markers>``.

    Examples
    --------
    >>> sniff(b"# beam\n8 3 0 0\n1 0 0 0\n"), sniff(b"8 2 0 0\n")
    (True, False)
    """
    first = next((ln for ln in head.splitlines() if ln.strip() and not ln.lstrip().startswith(b"#")), b"")
    return _HEAD.match(first) is not None


def check_sizes(path: str, name: str, head: bytes, bounds: ReadBounds) -> None:
    """Refuse the points of the ``.node`` or the tetrahedra of the ``.ele`` over ``bounds``, with their tables."""
    node, ele = tetgen_paths(path)
    for p, what, width in ((node, "points", 4), (ele, "cells", 3)):
        if not os.path.isfile(p):
            continue  # the reader names the missing companion
        with open(p, "rb") as fh:
            text = fh.read(1 << 16)
        first = next((ln.split(b"#", 1)[0].split() for ln in text.splitlines() if ln.split(b"#", 1)[0].split()),
                     [])
        try:
            nums = [int(t) for t in first[:width]]
        except ValueError:
            continue  # the reader names the header's defect
        nums += [0] * (width - len(nums))
        pname = os.path.basename(p)
        count, attrs = nums[0], nums[2]
        check_bounds(pname, bounds, *((count, 0) if what == "points" else (0, count)))
        # a table of count x (id, data, attributes, marker) numbers, allocated before it is read
        per = 1 + (3 + (nums[3] != 0) if what == "points" else max(nums[1], 4)) + max(attrs, 0)
        check_bounds(pname, bounds, nbytes=count * per * 8)
        check_holds(pname, f"{'nodes' if what == 'points' else 'elements'} with {per} numbers each", count, 2 * per,
                    os.path.getsize(p))


def _read(path: str, bounds: Any) -> Any:
    """The pair through :func:`read_tetgen` (its counts checked before, by :func:`check_sizes`)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_tetgen(path)


#: The format's entry in :data:`solver.io.registry.FORMATS`.
TETGEN = register_format(FileFormat(
    name="tetgen", title="TetGen mesh (.node + .ele)", extensions=(".node", ".ele"), aliases=("node", "ele"),
    sniff=sniff, sniff_order=1200,
    read=_read, main_path=lambda path: tetgen_paths(path)[0], check_sizes=check_sizes,
    check_complete=check_last_line,
    patcher=Patcher("tetgen", ("node", "ele"), ("node", "ele"), lambda raw, n: node_count(raw) == n, patch_node,
                    main="node", companions=("ele",)),
    writes=True,
    reads="a .node and its .ele (either names the pair), numbered from 0 or 1, with linear tetrahedra; boundary "
          "markers kept, region attributes as material regions; the .node coordinates written back in place in its own "
          "numbering, the .ele kept",
    refuses="a missing .ele (missing_companion), a table shorter than its header or cut in a line "
            "(truncated_file), an element naming an undefined node (undefined_node), 10-node tetrahedra "
            "(unsupported_element), counts over the read bounds"))
