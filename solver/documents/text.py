r"""Patterns of the names the documents hold, written so that Python, Rust (pydantic) and ECMAScript regexes agree.

``\s`` means different characters to each engine (Python counts ``\x1c``-``\x1f`` as white space,
Rust and ECMAScript do not), so the patterns list the characters: :data:`BLANKS` are the ones
Python's ``str.strip`` removes, which the documents' checks use.
"""

from __future__ import annotations

from typing import Any

__all__ = ["BLANKS", "HAS_TEXT", "NAME_START", "NOT_A_NAME", "ONE_LINE", "trimmed_name"]

#: Python's white space (``str.isspace``), as a character-class body.
BLANKS = r"\x09-\x0d\x1c-\x20\x85\xa0\u1680\u2000-\u200a\u2028\u2029\u202f\u205f\u3000"
#: A character other than white space somewhere (a pattern is a search: no anchors).
HAS_TEXT = f"[^{BLANKS}]"
#: How a trimmed name starts: neither a control character (below U+0020) nor white space.
NAME_START = f"^[^\\x00-\\x1f{BLANKS}]"
#: What a trimmed name holds nowhere: a control character, or white space at its end. (Said as a
#: ``not``: a Python ``$`` also matches before a final newline, so ``...[^{BLANKS}]$`` would admit one.)
NOT_A_NAME = f"[\\x00-\\x1f]|[{BLANKS}]$"


#: Beside a pattern anchored with ``$``: no line break, which a Python ``$`` would let end the text
#: (pydantic's regex engine and ECMAScript's do not).
ONE_LINE: dict[str, Any] = {"not": {"pattern": "\\n"}}


def trimmed_name(max_length: int) -> dict[str, Any]:
    """The JSON Schema of a name without control characters and without white space at either end."""
    return {"type": "string", "minLength": 1, "maxLength": max_length, "pattern": NAME_START,
            "not": {"pattern": NOT_A_NAME}}
