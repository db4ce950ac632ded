"""Validity: element quality, inversion checks, repair and mid-side node placement."""

from .quality import element_jacobians, element_quality, summarize_quality

__all__ = ["element_jacobians", "element_quality", "summarize_quality"]
