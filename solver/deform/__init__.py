"""The method: precompute once, solve per MOVE (Masuda & Ogawa, eq. 4.1-4.3)."""

from .deformer import Deformer, DeformResult, precompute

__all__ = ["Deformer", "DeformResult", "precompute"]
