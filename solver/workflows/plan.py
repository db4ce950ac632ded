"""The PLAN: one variant per row, one column per shape (a DOE table, a Tosca experiment plan).

A PLAN file is CSV: a header of shape names, then one row of numbers per
variant. Shapes without a column are 0 in every row. Rows are numbered from 1
(the first line under the header) in every message, file name and summary.
The delimiter is a comma, or a semicolon or a tab when the header has no
comma (spreadsheets in locales with decimal commas write ``;``).

:func:`parse_plan` takes rows already in memory (a service's JSON body):
dicts ``{shape: value}`` or lists under given column names.

Errors are :class:`~solver.errors.SpecError` naming the row (and its file
line), the column and the cell: ``empty_plan``, ``invalid_plan`` (a cell that
is not a finite number, a ragged row, a repeated or blank column name) and
``unknown_shape`` (a column that names no shape).
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import SolverError, SpecError
from ..limits import BLOCK_MAX, PLAN_ROWS_MAX, PLAN_TEXT_MAX, SHAPES_MAX
from .shapes import Shapes

__all__ = ["plan_table", "Plan", "parse_plan", "read_plan", "plan_values", "check_block", "MAX_ROWS"]

#: Rows a plan may hold (:data:`solver.limits.PLAN_ROWS_MAX`).
MAX_ROWS = PLAN_ROWS_MAX


@dataclass(frozen=True, eq=False)
class Plan:
    """A parsed plan.

    Attributes
    ----------
    columns : tuple of str
        Column names (shape names), in the plan's order.
    values : (m, c) float array
        One row per variant.
    lines : tuple of int or None
        The file line of each row (CSV files), for messages.
    """

    columns: tuple[str, ...]
    values: np.ndarray
    lines: tuple[int, ...] | None = None

    @property
    def rows(self) -> int:
        """Number of variants, m."""
        return int(self.values.shape[0])

    def where(self, i: int) -> str:
        """``"plan row 3 (line 4)"`` for the row of 0-based index ``i``."""
        line = f" (line {self.lines[i]})" if self.lines is not None else ""
        return f"plan row {i + 1}{line}"


def _number(cell: Any, where: str, column: str, text: bool) -> float:
    if text and isinstance(cell, str):
        s = cell.strip()
        try:
            v = float(s)
        except ValueError:
            raise SpecError(f"{where}, column {column!r}: {cell!r} is not a number", code="invalid_plan",
                            column=column, value=cell) from None
    elif isinstance(cell, (int, float)) and not isinstance(cell, bool):
        try:
            v = float(cell)
        except OverflowError:
            raise SpecError(f"{where}, column {column!r}: {cell!r} is too large", code="invalid_plan",
                            column=column) from None
    else:
        raise SpecError(f"{where}, column {column!r}: {cell!r} is not a number", code="invalid_plan",
                        column=column, value=repr(cell))
    if not math.isfinite(v):
        raise SpecError(f"{where}, column {column!r}: {cell!r} is not finite", code="invalid_plan",
                        column=column, value=str(cell))
    return v


def check_block(block: Any, code: str) -> None:
    """Refuse a block size (plan rows per stacked back-substitution) outside ``[1, BLOCK_MAX]``.

    Raises
    ------
    SpecError
        ``code``, field ``block``.
    """
    if isinstance(block, bool) or not isinstance(block, int) or not 1 <= block <= BLOCK_MAX:
        raise SpecError(f"block must be an integer in [1, {BLOCK_MAX}], got {block!r}", code=code, field="block")


def _columns(names: Sequence[Any]) -> tuple[str, ...]:
    if len(names) > SHAPES_MAX:
        raise SpecError(f"the plan has {len(names)} columns, more than {SHAPES_MAX} (one per shape)",
                        code="invalid_plan", columns=len(names))
    cols = []
    for k, c in enumerate(names):
        if not isinstance(c, str) or not c.strip():
            raise SpecError(f"plan column {k + 1} has no name ({c!r}); the header names one shape per column",
                            code="invalid_plan", column=k + 1)
        cols.append(c.strip())
    dup = sorted({c for c in cols if cols.count(c) > 1})
    if dup:
        raise SpecError(f"plan columns {dup} appear more than once", code="invalid_plan", columns=dup)
    return tuple(cols)


def parse_plan(rows: Sequence[Mapping[str, Any] | Sequence[Any]], columns: Sequence[str] | None = None,
               lines: Sequence[int] | None = None, text: bool = False) -> Plan:
    """A plan from rows in memory.

    Parameters
    ----------
    rows : sequence
        Dicts ``{shape: number}`` (a shape a row does not name is 0 there), or,
        with ``columns``, sequences of one number per column.
    columns : sequence of str, optional
        Column names of sequence rows.
    lines : sequence of int, optional
        File line of each row, for messages.
    text : bool
        Cells are text to parse as numbers (CSV); else they must be numbers
        (JSON numbers, not booleans or strings).

    Returns
    -------
    Plan

    Raises
    ------
    SpecError
        No rows, a cell that is not a finite number, a row with the wrong
        number of cells, a blank or repeated column name.

    Examples
    --------
    >>> p = parse_plan([{"a": 1, "b": 0.5}, {"a": -1}])
    >>> p.columns, p.values.tolist()
    (('a', 'b'), [[1.0, 0.5], [-1.0, 0.0]])
    """
    if isinstance(rows, (str, bytes)) or not isinstance(rows, Sequence):
        raise SpecError(f"a plan is a list of rows, got {type(rows).__name__}", code="invalid_plan")
    if not rows:
        raise SpecError("the plan has no rows (one variant per row under the header)", code="empty_plan")
    if len(rows) > MAX_ROWS:
        raise SpecError(f"the plan has {len(rows)} rows, more than {MAX_ROWS}", code="invalid_plan")
    ln = tuple(int(v) for v in lines) if lines is not None else None

    def where(i: int) -> str:
        return f"plan row {i + 1}" + (f" (line {ln[i]})" if ln is not None else "")

    if columns is None:
        seen: dict[str, None] = {}
        for i, row in enumerate(rows):
            if not isinstance(row, Mapping):
                raise SpecError(f"{where(i)} must be an object {{shape: value}} (or give the column names)",
                                code="invalid_plan")
            for key in row:
                seen.setdefault(key, None)
        cols = _columns(list(seen))
        values = np.zeros((len(rows), len(cols)))
        for i, row in enumerate(rows):
            assert isinstance(row, Mapping)
            for j, c in enumerate(cols):
                if c in row:
                    values[i, j] = _number(row[c], where(i), c, text)
        return Plan(cols, values, ln)
    cols = _columns(columns)
    values = np.zeros((len(rows), len(cols)))
    for i, row in enumerate(rows):
        if isinstance(row, (str, bytes, Mapping)) or not isinstance(row, Sequence):
            raise SpecError(f"{where(i)} must be a list of {len(cols)} numbers", code="invalid_plan")
        if len(row) != len(cols):
            raise SpecError(f"{where(i)} has {len(row)} cells, the header {len(cols)} ({list(cols)})",
                            code="invalid_plan", cells=len(row), columns=len(cols))
        for j, c in enumerate(cols):
            values[i, j] = _number(row[j], where(i), c, text)
    return Plan(cols, values, ln)


def plan_table(text: str) -> list[tuple[int, list[str]]]:
    """The non-blank rows of CSV plan text with their row numbers (1-based), the delimiter sniffed.

    The delimiter is ``,`` unless the first non-blank line has ``;`` or a tab and no comma.

    Raises
    ------
    SpecError
        ``invalid_plan`` for text the CSV reader cannot split (naming the line).
    """
    first = next((ln for ln in text.splitlines() if ln.strip()), "")
    delim = "," if "," in first or not any(d in first for d in ";\t") else (";" if ";" in first else "\t")
    reader = csv.reader(io.StringIO(text), delimiter=delim)
    try:
        table = [(k + 1, row) for k, row in enumerate(reader)]
    except csv.Error as e:
        raise SpecError(f"the plan is not CSV text the reader can split at line {reader.line_num}: {e}",
                        code="invalid_plan", field="plan") from None
    return [(k, row) for k, row in table if any(c.strip() for c in row)]


def read_plan(path: str | os.PathLike[str]) -> Plan:
    """Read a CSV plan file.

    Blank lines are skipped; a UTF-8 byte-order mark is ignored.

    Raises
    ------
    SolverError
        The file does not exist (``file_not_found``).
    SpecError
        As :func:`parse_plan`, with file lines in the messages; an empty file.
    """
    try:
        with open(path, encoding="utf-8-sig", newline="") as fh:
            text = fh.read()
    except FileNotFoundError:
        raise SolverError(f"PLAN file not found: {os.fspath(path)}", code="file_not_found") from None
    except UnicodeDecodeError as e:
        raise SpecError(f"PLAN file {os.fspath(path)} is not UTF-8 text: {e}", code="invalid_plan") from None
    if len(text) > PLAN_TEXT_MAX:
        raise SpecError(f"PLAN file {os.fspath(path)} holds {len(text)} characters, more than {PLAN_TEXT_MAX}",
                        code="invalid_plan")
    table = plan_table(text)
    if not table:
        raise SpecError(f"PLAN file {os.fspath(path)} is empty: it needs a header of shape names and one row "
                        "per variant", code="empty_plan")
    header = table[0][1]
    body = table[1:]
    if not body:
        raise SpecError(f"PLAN file {os.fspath(path)} has a header but no rows", code="empty_plan")
    return parse_plan([row for _, row in body], header, [k for k, _ in body], text=True)


def plan_values(plan: Plan, shapes: Shapes) -> np.ndarray:
    """The plan as parameters (m, K) in ``shapes.names`` order (shapes without a column are 0).

    Raises
    ------
    SpecError
        A column that names no shape (``unknown_shape``).
    """
    unknown = [c for c in plan.columns if c not in shapes.names]
    if unknown:
        raise SpecError(f"plan column(s) {unknown} name no shape; the shapes are {list(shapes.names)}",
                        code="unknown_shape", columns=unknown)
    out = np.zeros((plan.rows, shapes.count))
    for j, c in enumerate(plan.columns):
        out[:, shapes.names.index(c)] = plan.values[:, j]
    return out
