"""The SPEC document (defined once, in :mod:`solver.documents.spec`) and the service's checks of it.

:func:`check_spec_ids` checks vertex ids against the stored mesh before a session is built, and
:func:`stored_surfaces` lists the stored surfaces a SPEC names.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import Any

from solver.documents.spec import Selection, Spec, Target

from ..errors import ServiceError

__all__ = ["Spec", "Selection", "Target", "check_spec_ids", "check_selection_ids", "check_solve_options",
           "stored_surfaces"]

def _bad_ids(ids: list[int], n: int) -> list[int]:
    return [i for i in ids if not 0 <= i < n]


def check_selection_ids(sel: dict[str, Any], n: int, where: str) -> None:
    """Refuse vertex ids of a selection outside ``[0, n)`` (422 ``index_out_of_range``)."""
    bad = _bad_ids(sel.get("ids") or [], n)
    if bad:
        raise ServiceError("index_out_of_range", f"{where}.ids has vertex ids outside [0, {n}): {bad[:10]}",
                           field=f"{where}.ids", ids=bad[:10], vertices=n)


def check_spec_ids(spec: dict[str, Any], n: int) -> None:
    """Refuse every vertex id of a SPEC outside ``[0, n)``, naming the field.

    Raises
    ------
    ServiceError
        422 ``index_out_of_range``.
    """
    for name, sel in (spec.get("selections") or {}).items():
        check_selection_ids(sel, n, f"SPEC.selections.{name}")
    for key in ("points", "motion", "relative"):
        for k, e in enumerate(spec.get(key) or []):
            parts = [(f"SPEC.{key}[{k}]", e)] + [(f"SPEC.{key}[{k}].points[{q}]", p)
                                                  for q, p in enumerate(e.get("points") or [])]
            for where, part in parts:
                for f in ("vertices", "edge", "face"):
                    bad = _bad_ids(part.get(f) or [], n)
                    if bad:
                        raise ServiceError("index_out_of_range", f"{where}.{f} has vertex ids outside "
                                           f"[0, {n}): {bad[:10]}", field=f"{where}.{f}", ids=bad[:10], vertices=n)
    ties = spec.get("ties")
    if isinstance(ties, list):
        for k, pair in enumerate(ties):
            bad = _bad_ids(pair, n)
            if bad:
                raise ServiceError("index_out_of_range", f"SPEC.ties[{k}] has vertex ids outside [0, {n}): "
                                   f"{bad}", field=f"SPEC.ties[{k}]", ids=bad, vertices=n)



def check_solve_options(spec: dict[str, Any], allowed: Collection[str]) -> None:
    """Refuse a SPEC whose ``solve_options`` set a field outside ``allowed`` (the service's setting).

    Raises
    ------
    ServiceError
        422 ``solve_option_not_allowed`` naming the field.
    """
    given = spec.get("solve_options") or {}
    refused = sorted(k for k, v in given.items() if v is not None and k not in allowed) \
        if isinstance(given, dict) else []
    if refused:
        raise ServiceError("solve_option_not_allowed", f"SPEC.solve_options.{refused[0]} is the service's to "
                           f"choose; a SPEC may set {sorted(allowed) or 'none of them'}",
                           field=f"SPEC.solve_options.{refused[0]}", allowed=sorted(allowed))


def stored_surfaces(spec: dict[str, Any]) -> list[tuple[int, str]]:
    """``(k, mesh_id)`` of every SPEC target whose surface is a stored mesh.

    Examples
    --------
    >>> stored_surfaces({"targets": [{"surface": {"mesh_id": "m_1"}}, {"surface": {"vertices": []}}]})
    [(0, 'm_1')]
    """
    out = []
    for k, t in enumerate(spec.get("targets") or []):
        surf = t.get("surface") if isinstance(t, dict) else None
        if isinstance(surf, dict) and isinstance(surf.get("mesh_id"), str):
            out.append((k, surf["mesh_id"]))
    return out
