"""JSON documents on disk for the command line: SPEC, MOVE, SHAPES files in, REPORTs out."""

from __future__ import annotations

import json
import os
import sys
from typing import Any

import numpy as np

from ..errors import SolverError

__all__ = ["load_json", "dump_json"]


def load_json(path: str, what: str) -> Any:
    """The JSON document in ``path``; ``what`` names it in errors (``file_not_found``, ``invalid_json``)."""
    try:
        with open(path, encoding="utf-8") as fh:
            return json.load(fh)
    except FileNotFoundError:
        raise SolverError(f"{what} file not found: {path}", code="file_not_found") from None
    except json.JSONDecodeError as e:
        raise SolverError(f"{what} file {path} is not valid JSON: {e}", code="invalid_json") from None


def dump_json(obj: Any, path: str | None) -> None:
    """Write ``obj`` as indented JSON to ``path``, or to stdout for None or ``-`` (arrays as lists)."""
    text = json.dumps(obj, indent=2, default=lambda o: o.tolist() if isinstance(o, np.ndarray) else str(o))
    if path is None or path == "-":
        sys.stdout.write(text + "\n")
        sys.stdout.flush()
        return
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(text + "\n")
