"""Constraints: the SPEC and MOVE documents, selections, features, ties and constraint rows."""

from .selection import select
from .spec import HandleMove, Move, Spec, parse_move, parse_spec

__all__ = ["select", "HandleMove", "Move", "Spec", "parse_move", "parse_spec"]
