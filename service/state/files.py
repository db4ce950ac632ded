"""Files of the data directory: ids that can name one, and atomic replacement of a JSON record."""

from __future__ import annotations

import contextlib
import json
import os
import re
import tempfile
from pathlib import Path
from typing import Any

__all__ = ["valid_id", "write_json"]

_ID = re.compile(r"^[A-Za-z0-9_-]{1,64}$")


def valid_id(ident: str) -> bool:
    """True if ``ident`` can name a file in the data directory (no path tricks)."""
    return bool(_ID.match(ident))


def write_json(path: Path, doc: dict[str, Any] | list[Any]) -> None:
    """Replace ``path`` with ``doc`` atomically: all of it, or (the disk full, say) the file as it was."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".json")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(doc, f)
            f.flush()
            os.fsync(f.fileno())  # on the disk before it replaces the record: no rename of a file still empty
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
