"""Constraints: the SPEC and MOVE documents, selections, features, ties and constraint rows."""

from .move import HandleMove, MoveBounds, ResolvedMove, parse_move, scaled_move
from .selection import select
from .spec import ResolvedSpec, parse_spec

__all__ = ["select", "HandleMove", "ResolvedMove", "MoveBounds", "ResolvedSpec", "parse_move", "parse_spec",
           "scaled_move"]
