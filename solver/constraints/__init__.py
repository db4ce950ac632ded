"""Constraints: the SPEC and MOVE documents, selections, features, ties and constraint rows."""

from .move import HandleMove, Move, MoveBounds, parse_move, scaled_move
from .selection import select
from .spec import Spec, parse_spec

__all__ = ["select", "HandleMove", "Move", "MoveBounds", "Spec", "parse_move", "parse_spec", "scaled_move"]
