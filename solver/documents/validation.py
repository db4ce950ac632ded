"""A document validated by its model, with the model's errors as a :class:`~solver.errors.SpecError`."""

from __future__ import annotations

import re
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from ..errors import SpecError

__all__ = ["validated", "error_path", "describe"]

M = TypeVar("M", bound=BaseModel)


def error_path(what: str, loc: tuple[Any, ...]) -> tuple[str, str]:
    """``(field, where)`` of a pydantic error location under the document ``what``.

    ``field`` names the member (``MOVE.handles.tip.translation``); ``where`` adds the list index
    (``MOVE.handles.tip.translation[2]``).

    Examples
    --------
    >>> error_path("MOVE", ("handles", "tip", "translation", 2))
    ('MOVE.handles.tip.translation', 'MOVE.handles.tip.translation[2]')
    """
    field, where = what, what
    for part in loc:
        if isinstance(part, int):
            where += f"[{part}]"
        else:
            field = f"{where}.{part}"
            where = field
    return field, where


#: Error types that say an input is not of a union member's kind at all (the member that fits says more).
_MISMATCH = {"none_required", "bool_type", "string_type", "list_type", "literal_error", "model_type", "dict_type",
             "float_type", "int_type", "model_attributes_type", "is_instance_of"}


#: pydantic's name for a union member that is a number or a string with bounds (``t: Fraction | None``).
_CONSTRAINED = re.compile(r"constrained-(float|int|str|bytes|decimal)")


def _is_tag(part: Any) -> bool:
    """True for the name pydantic gives a member of a union in an error's location (``Box``, ``str``, ...)."""
    if not isinstance(part, str):
        return False
    return (part in {"str", "int", "float", "bool", "none"} or any(c in part for c in "[(")
            or _CONSTRAINED.fullmatch(part) is not None or (part[:1].isupper() and part in _model_names()))


def _model_names() -> set[str]:
    from . import move, spec  # the documents whose members can be union members (their edits' models too)

    return {n for mod in (move, spec) for n in (*dir(mod), *mod._EDIT_MODELS) if isinstance(getattr(mod, n), type)
            and issubclass(getattr(mod, n), BaseModel)}


def _is_key(doc: Any, path: tuple[Any, ...], name: Any) -> bool:
    """True when ``name`` is a key of the dictionary the document holds at ``path`` (a name a person chose)."""
    node = doc
    for part in path:
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
            node = node[part]
        else:
            return False
    return isinstance(node, dict) and name in node


def _tag_at(loc: tuple[Any, ...], start: int, doc: Any) -> int:
    return next((i for i, part in enumerate(loc) if i > max(start, 0) and isinstance(loc[i - 1], str)
                 and _is_tag(part) and not _is_key(doc, loc[:i], part)), -1)


def _fitting_members(errors: list[Any], doc: Any, start: int = 0) -> list[Any]:
    """The errors of the union member that fits the input best, without the members' names in their locations.

    pydantic reports an input that matches no member of a union once per member; a person wants to
    hear about the member they meant: the one with the fewest errors among those whose kind matched.
    A name that looks like a member's but is a key of the document at its place (a handle called
    ``tip(1)`` or ``str``) is the person's, kept as it is; so is a name alone at its place.
    """
    groups: dict[tuple[Any, ...], dict[Any, list[Any]]] = {}
    out = []
    for err in errors:
        loc = tuple(err.get("loc", ()))
        i = _tag_at(loc, start, doc)
        if i < 0:
            out.append(err)
        else:
            groups.setdefault(loc[:i], {}).setdefault(loc[i], []).append(err)
    for prefix, members in groups.items():
        i = len(prefix)
        if len(members) == 1:
            name, errs = next(iter(members.items()))
            if name == "[key]":  # an error in a dictionary's key: named at the key
                out.extend(_fitting_members([{**e, "loc": tuple(e["loc"])[:i]} for e in errs], doc, i - 1))
            else:  # not a union: one name, every error under it
                out.extend(_fitting_members(errs, doc, i))
            continue

        def score(errs: list[Any]) -> tuple[int, int]:
            whole = all(len(e["loc"]) == len(errs[0]["loc"]) and e.get("type") in _MISMATCH for e in errs)
            return (1 if whole else 0, len(errs))
        best = min(members.values(), key=score)
        out.extend(_fitting_members([{**e, "loc": tuple(e["loc"])[:i] + tuple(e["loc"])[i + 1:]} for e in best],
                                    doc, i - 1))
    return out


def _got(err: Any) -> str:
    if "input" not in err or isinstance(err["input"], (dict, list)) or err.get("type") == "missing":
        return ""
    text = repr(err["input"])
    return f", got {text[:60]}{'...' if len(text) > 60 else ''}"


def describe(what: str, loc: tuple[Any, ...], err: Any) -> tuple[str, str, str]:
    """``(field, where, message)`` of one pydantic error at ``loc`` under the document ``what``."""
    if err.get("type") == "extra_forbidden":  # named in its parent, as the member that is not there
        field, where = error_path(what, loc[:-1])
        return field, where, f"unknown field {str(loc[-1])!r} in {where}"
    field, where = error_path(what, loc)
    return field, where, f"{where}: {str(err.get('msg', '')).removeprefix('Value error, ')}{_got(err)}"


def validated(model: type[M], doc: Any, what: str, context: dict[str, Any] | None = None) -> M:
    """``doc`` as an instance of ``model``; else a :class:`SpecError` naming the first wrong field.

    Parameters
    ----------
    model : type of pydantic.BaseModel
    doc : Any
        The document as parsed from JSON (or an instance of ``model``, returned as it is).
    what : str
        The document's name in messages, e.g. ``"MOVE"``.
    context : dict, optional
        pydantic's validation context (``{"files": True}``: a SPEC's target surface may be a file path).

    Raises
    ------
    SpecError
        ``details["field"]`` names the wrong member; ``details["errors"]`` lists every error found.

    Examples
    --------
    >>> from solver.documents.move import Move
    >>> validated(Move, {"handles": {"h": {"scale": True}}}, "MOVE")
    Traceback (most recent call last):
    ...
    solver.errors.SpecError: MOVE.handles.h.scale: Input should be a valid number, got True
    """
    if isinstance(doc, model):
        return doc
    try:
        return model.model_validate(doc, context=context)
    except ValidationError as e:
        errors = []
        for err in _fitting_members(list(e.errors(include_url=False)), doc):
            # a rule over several fields (a model validator) names the one it blames in its context's "at"
            loc = tuple(err.get("loc", ())) or tuple((err.get("ctx") or {}).get("at", ()))
            field, where, text = describe(what, loc, err)
            errors.append({"field": field, "where": where, "message": text, "loc": list(loc),
                           "type": err.get("type"), "msg": str(err.get("msg", "")), "got": _got(err)})
        first = errors[0]
        more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
        raise SpecError(first["message"] + more, field=first["field"], errors=errors[:20]) from None
