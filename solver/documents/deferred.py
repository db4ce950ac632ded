"""Members of a document whose validators are made when a document first gives them.

A pydantic model builds its validator when its class is made, and a document's validator holds every
member's. Most SPECs name no edit, point, motion, symmetry or target, and most MOVEs move only
handles, so the SPEC and MOVE hold those members as :class:`OnFirstUse`: an empty list (or
dictionary) is taken as it is, and anything else goes to a validator of the member's type, made
when first needed. Its errors are merged into the document's under the member's name, with the
same locations (``radius[0].axis``), types and messages; the JSON Schema is the member type's, the
same bytes. The edits' models are not even imported until then (:mod:`~solver.documents.edits`,
:mod:`~solver.documents.edit_moves`); the other members' models are defined with
``defer_build=True``, so that making their classes builds nothing.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Annotated, Any, get_origin

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    GetCoreSchemaHandler,
    GetJsonSchemaHandler,
    TypeAdapter,
    ValidationInfo,
)
from pydantic.json_schema import JsonSchemaValue
from pydantic_core import CoreSchema, core_schema

__all__ = ["OnFirstUse", "build"]


class OnFirstUse:
    """``Annotated`` metadata of a list or dictionary member: its validator is made on first use.

    Parameters
    ----------
    max_length : int
        The most items the member holds.
    item : callable, optional
        Returns the type of the member's items (an edit's model, from a module imported then); by
        default the annotated type's own.

    Examples
    --------
    >>> from typing import Annotated
    >>> from pydantic import BaseModel
    >>> class Doc(BaseModel):
    ...     xs: Annotated[list[int], OnFirstUse(3)] = []
    >>> Doc(xs=[1, 2]).xs, Doc(xs=[]).xs
    ([1, 2], [])
    >>> try:
    ...     Doc(xs=[1, 2, 3, 4])
    ... except ValueError as e:
    ...     print([(err["loc"], err["type"]) for err in e.errors()])
    [(('xs',), 'too_long')]
    """

    def __init__(self, max_length: int, item: Callable[[], Any] | None = None) -> None:
        self.max_length = max_length
        self._item = item
        self._source: Any = None
        self._adapter: TypeAdapter[Any] | None = None

    @property
    def built(self) -> bool:
        """Whether the member's validator has been made."""
        return self._adapter is not None

    def adapter(self) -> TypeAdapter[Any]:
        """The member's validator (strict, as the documents are), made on first call.

        Two threads that first use it at once may both make it; either is the same validator.
        """
        if self._adapter is None:
            tp = self._source
            if self._item is not None:  # list[Any] or dict[str, Any]: the items' type, now
                item = self._item()
                tp = list[item] if get_origin(tp) is list else dict[str, item]  # type: ignore[valid-type]
            bounded: Any = Annotated[tp, Field(max_length=self.max_length)]
            self._adapter = TypeAdapter(bounded, config=ConfigDict(strict=True))
        return self._adapter

    def _validate(self, value: Any, info: ValidationInfo) -> Any:
        if type(value) is get_origin(self._source) and not value:
            return type(value)()
        # The documents hold lists, dictionaries, strings, numbers and booleans, which strict
        # validation of Python values takes as it takes JSON's; pydantic merges the errors raised
        # here into the document's, under the member's name.
        return self.adapter().validate_python(value, context=info.context)

    def __get_pydantic_core_schema__(self, source: Any, handler: GetCoreSchemaHandler) -> CoreSchema:
        if self._source is not None and self._source != source:
            raise TypeError(f"one OnFirstUse per member: {self._source} and {source}")
        self._source = source
        return core_schema.with_info_plain_validator_function(self._validate)

    def __get_pydantic_json_schema__(self, schema: CoreSchema, handler: GetJsonSchemaHandler) -> JsonSchemaValue:
        return handler(self.adapter().core_schema)


def build(*models: type[BaseModel]) -> None:
    """Make now the validator of every :class:`OnFirstUse` member of ``models``."""
    for model in models:
        for info in model.model_fields.values():
            for meta in info.metadata:
                if isinstance(meta, OnFirstUse):
                    meta.adapter()
