"""Fixed-width Fortran fields of Ansys MAPDL archives (``.cdb``): numbers read from their columns, and written.

A ``.cdb`` block's rows are the columns of its Fortran format line
(``(3i8,6e20.13)``: 3 integers of 8 columns, then reals of 20). The fields of
all the rows of a block are read at once from a (rows, width) array of bytes
(:func:`_grid`, :func:`_field`), a blank field being 0; :func:`fortran_real`
reads one real as Fortran writes it and :func:`fortran_e` writes one in a
``1PEw.d[Ee]`` format. :func:`_error` is the
:class:`~solver.errors.UnreadableFileError` that names a deck's line.
"""

from __future__ import annotations

import re

import numpy as np

from ..errors import UnreadableFileError

_REAL = re.compile(rb"^\s*([+-]?(?:\d+\.?\d*|\.\d+))(?:[EeDd]([+-]?\d+)|([+-]\d+))?\s*$")


def _error(name: str, line: int | None, what: str, code: str = "unreadable_file", **details: object
           ) -> UnreadableFileError:
    where = f"{name!r} line {line}:" if line is not None else repr(name)
    return UnreadableFileError(f"{where} {what}", code=code, file=name, **({"line": line} if line else {}),
                               **details)


# ------------------------------------------------------------------ numbers


def fortran_real(text: bytes) -> float:
    """The value of a Fortran real field (blank is 0; ``D`` exponents; ``1.0-100`` without ``E``).

    Examples
    --------
    >>> fortran_real(b" 1.5000000000000E+00"), fortran_real(b"-2.5D-3"), fortran_real(b"1.0-100"), fortran_real(b"  ")
    (1.5, -0.0025, 1e-100, 0.0)
    """
    if not text.strip():
        return 0.0
    m = _REAL.match(text)
    if m is None:
        raise ValueError(f"not a real number: {text.decode('ascii', 'replace').strip()!r}")
    exp = m.group(2) or m.group(3) or b"0"
    return float(m.group(1) + b"e" + exp)


def fortran_e(x: float, w: int, d: int, e: int | None = None) -> str:
    """``x`` as MAPDL writes it with the Fortran format ``1PEw.d[Ee]``: one digit before the point, right-justified.

    Without ``Ee`` the exponent has two digits, and three without the ``E`` past 99, as Fortran writes
    it. A value the field cannot hold with ``d`` decimals is written with as many as fit.

    Parameters
    ----------
    x : float
    w, d : int
        Field width and decimals.
    e : int, optional
        Exponent digits.

    Returns
    -------
    str
        ``w`` characters.

    Raises
    ------
    ValueError
        ``x`` is not finite, or does not fit ``w`` columns with one decimal.

    Examples
    --------
    >>> fortran_e(1.0, 20, 13), fortran_e(-0.5, 20, 13)
    (' 1.0000000000000E+00', '-5.0000000000000E-01')
    >>> fortran_e(-0.28749388208227, 21, 13, 3), fortran_e(2.5e-120, 20, 13)
    ('-2.8749388208227E-001', ' 2.5000000000000-120')
    >>> fortran_e(-1.0 / 3.0, 12, 9)
    '-3.33333E-01'
    """
    if not np.isfinite(x):
        raise ValueError(f"{x} is not a finite coordinate")
    for dec in range(d, 0, -1):
        mant, _, ex = f"{x:.{dec}E}".partition("E")
        n = int(ex)
        if e is not None:
            text = f"{mant}E{n:+0{e + 1}d}" if abs(n) < 10 ** e else ""
        else:
            text = f"{mant}E{n:+03d}" if abs(n) < 100 else f"{mant}{n:+04d}" if abs(n) < 1000 else ""
        if text and len(text) <= w:
            return text.rjust(w)
    raise ValueError(f"{x!r} does not fit a field of {w} columns (format e{w}.{d}{'' if e is None else f'e{e}'})")


def _grid(rows: list[bytes], width: int) -> np.ndarray:
    """(n, width) uint8: each row cut or padded with blanks to ``width`` columns."""
    if not rows or width <= 0:
        return np.full((len(rows), max(width, 0)), 32, np.uint8)
    buf = b"".join(rows)
    if len(buf) != width * len(rows) or any(len(r) != width for r in rows):
        buf = b"".join([r[:width].ljust(width) for r in rows])
    return np.frombuffer(buf, np.uint8).reshape(len(rows), width)


def _field(A: np.ndarray, start: int, width: int) -> np.ndarray:
    """(n, width) uint8 copy of columns ``start`` .. ``start + width`` of ``A``, blanks past its end."""
    out = np.full((A.shape[0], width), 32, np.uint8)
    have = max(0, min(width, A.shape[1] - start))
    out[:, :have] = A[:, start:start + have]
    return out


def _as_text(F: np.ndarray) -> np.ndarray:
    """(n,) bytes strings of the rows of a (n, width) uint8 array."""
    return np.ascontiguousarray(F).view(f"S{F.shape[1]}").ravel()


def _ints(F: np.ndarray) -> tuple[np.ndarray, int | None]:
    """Integers of the fields ``F`` (n, width) uint8; blank fields are 0.

    Returns the values (n,) and the first row that is not an integer, or None (then the values
    are not to be used).
    """
    F = F.copy()
    F[(F == 32).all(axis=1), -1] = ord("0")
    text = _as_text(F)
    try:
        return text.astype(np.int64), None
    except (ValueError, OverflowError):
        pass
    bad = next((r for r, t in enumerate(text.tolist()) if not _is_int(t)), 0)
    return np.zeros(len(text), np.int64), bad


def _reals(F: np.ndarray) -> tuple[np.ndarray, int | None]:
    """Reals of the fields ``F`` (n, width) uint8 (blank is 0); the first row that is no real, or None."""
    F = F.copy()
    F[(F == 32).all(axis=1), -1] = ord("0")
    text = _as_text(F)
    try:
        return text.astype(np.float64), None
    except ValueError:
        pass
    out = np.empty(len(text))
    for r, t in enumerate(text.tolist()):
        try:
            out[r] = fortran_real(t)
        except ValueError:
            return out, r
    return out, None


def _is_int(text: bytes) -> bool:
    try:
        int(text)
    except (ValueError, OverflowError):
        return False
    return True


def _count(n: int, what: str) -> str:
    """``n`` and ``what``, plural unless one: ``_count(2, "element")`` is ``"2 elements"``."""
    return f"{n} {what}{'' if n == 1 else 's'}"


def _shown(b: bytes) -> str:
    return b.decode("ascii", "replace").strip()
