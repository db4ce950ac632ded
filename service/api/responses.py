"""The JSON response class: JSON has no infinity or NaN, so such numbers are written as null."""

from __future__ import annotations

import json
import math
from typing import Any

from starlette.responses import JSONResponse as _StarletteJSON

__all__ = ["JSONResponse", "finite_json"]


def finite_json(doc: Any) -> Any:
    """A copy of a JSON-like document with non-finite floats replaced by None.

    Examples
    --------
    >>> finite_json({"a": [1.0, float("inf")], "b": float("nan")})
    {'a': [1.0, None], 'b': None}
    """
    if isinstance(doc, float):
        return doc if math.isfinite(doc) else None
    if isinstance(doc, dict):
        return {k: finite_json(v) for k, v in doc.items()}
    if isinstance(doc, (list, tuple)):
        return [finite_json(v) for v in doc]
    return doc


class JSONResponse(_StarletteJSON):
    """Starlette's JSON response, writing non-finite numbers as null instead of failing."""

    def render(self, content: Any) -> bytes:
        """Encode ``content``; a non-finite number becomes null."""
        try:
            return super().render(content)
        except ValueError:  # "Out of range float values are not JSON compliant"
            return json.dumps(finite_json(content), ensure_ascii=False, allow_nan=False,
                              separators=(",", ":")).encode("utf-8")
