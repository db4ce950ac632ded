"""The daily edits' kinds, apart from their entries and values, which are loaded when a SPEC names an edit.

Most SPECs name none: the modules that parse, resolve and assemble edits
(:mod:`~solver.constraints.edit_entries`, :mod:`~solver.constraints.edit_values`,
:mod:`~solver.constraints.edits`, :mod:`~solver.constraints.feature_edits`,
:mod:`~solver.constraints.resolve_edits`) are imported by the functions that need them, so that
``import solver`` and a set-up without edits do not load them.
"""

__all__ = ["EDIT_KINDS", "NOMINAL_KINDS"]

#: The SPEC and MOVE keys of the edits, in the order their rows are ranked.
EDIT_KINDS = ("radius", "twist", "map", "offset", "lattice", "fillet", "distance", "angle")

#: The kinds whose MOVE gives a value or its change from the edit's nominal rest value.
NOMINAL_KINDS = ("radius", "fillet", "distance", "angle")
