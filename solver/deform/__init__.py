"""The method: precompute once, solve per MOVE (Masuda & Ogawa, eq. 4.1-4.3)."""

from .deformer import Deformer, precompute
from .update import DeformResult

__all__ = ["Deformer", "DeformResult", "precompute"]
