"""A solver in the loop: every plan row morphed, written, run through an FE solver, and its responses tabled.

::

    tetmorph study MESH --spec SPEC --shapes SHAPES --plan PLAN --solver 'ccx -i {stem}'
    tetmorph study ... --response ccx --output 'out/{i}/deck.inp' --table study.csv [--timeout 600]

The rows are morphed as ``tetmorph doe`` morphs them (stacked solves), with
the ``reject`` inversion policy unless told otherwise: a row that inverts an
element is recorded and not solved. Each written deck is then handed to the
solver command, run in the deck's folder with a time limit; ``{stem}``,
``{deck}``, ``{dir}`` and ``{i}`` in the command become the deck's name
without extension, its path, its folder and the plan row. A failed or
timed-out run, or a response reader that raises, is recorded in the row and
the study goes on.

Responses come from a reader: ``ccx`` (:func:`ccx_responses`, CalculiX's
``.dat`` file) or a Python file defining ``response(deck: pathlib.Path) ->
dict[str, float]``.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shlex
import shutil
import subprocess
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..deform.deformer import Deformer
from ..errors import SolverError
from ..io.abaqus_deck import is_assembly
from ..mesh import Mesh
from .doe import BLOCK, DoeResult, deck_writer, run_doe, write_rows
from .plan import Plan
from .shapes import Shapes

__all__ = ["StudyRow", "ccx_responses", "load_response", "load_reader", "morph_rows", "study_rows", "solve_row",
           "read_run", "run_study", "write_table", "DEFAULT_TIMEOUT_S"]

#: Seconds a solver run may take before it is stopped and recorded as ``timeout``.
DEFAULT_TIMEOUT_S = 600.0
#: Seconds between two looks at a running solver's time limit and cancellation.
_POLL_S = 0.1

Response = Callable[[Path], dict[str, float]]


@dataclass
class StudyRow:
    """One plan row of a study.

    Attributes
    ----------
    row : int
    parameters : dict of str to float
    status : str
        ``ok``; ``rejected`` or ``conflict`` (the morph, as in ``tetmorph doe``:
        not solved); ``solver_failed`` (non-zero exit, or ``*ERROR`` in its
        output); ``timeout``; ``response_failed``; ``cancelled`` (its run was
        killed by :func:`solve_row`'s ``cancelled``).
    inverted, min_scaled_jacobian, max_displacement : mesh figures of the morph
    deck : str or None
    solver_s : float or None
        Wall time of the solver run.
    responses : dict of str to float
    message : str
        What went wrong, for a row that is not ``ok``.
    """

    row: int
    parameters: dict[str, float]
    status: str
    inverted: int | None
    min_scaled_jacobian: float | None
    max_displacement: float | None
    deck: str | None = None
    solver_s: float | None = None
    responses: dict[str, float] = field(default_factory=dict)
    message: str = ""


def _dat_blocks(text: str) -> dict[str, np.ndarray]:
    """Every numeric block of a CalculiX ``.dat`` file by its heading (first words), the first of each name.

    A heading is the first text line after a block of numbers (or at the start);
    text lines before its first numbers (column headings) keep it.
    """
    blocks: dict[str, np.ndarray] = {}
    title: str | None = None
    rows: list[list[float]] = []

    def close() -> None:
        if title is not None and rows and title not in blocks:
            width = max(len(r) for r in rows)
            blocks[title] = np.array([r + [np.nan] * (width - len(r)) for r in rows])

    for ln in text.splitlines():
        s = ln.strip()
        if not s:
            continue
        if re.match(r"^[-+]?[0-9.]", s):
            try:
                rows.append([float(v) for v in s.split()])
                continue
            except ValueError:
                pass
        if rows:
            close()
            rows, title = [], None
        if title is None:
            title = s.split(" for set ")[0].split(" (")[0].strip()
    close()
    return blocks


def _frd_blocks(text: str) -> dict[str, np.ndarray]:
    """The nodal result blocks of a CalculiX ``.frd`` file (the last of each name): ``{"DISP": (n, 1 + 3)}``.

    Each block opens with ``-4  NAME`` and lists ``-1`` lines: the node id in
    columns 4-13, then one 12-column value per component.
    """
    out: dict[str, np.ndarray] = {}
    name: str | None = None
    rows: list[list[float]] = []
    for line in text.splitlines():
        if line.startswith(" -4"):
            name, rows = line.split()[1], []
        elif line.startswith(" -1") and name is not None:
            vals = [line[13 + 12 * k:25 + 12 * k] for k in range((len(line) - 13) // 12)]
            rows.append([float(line[3:13]), *(float(v) for v in vals)])
        elif line.startswith(" -3") and name is not None:
            if rows:
                out[name] = np.array(rows)
            name = None
    return out


def _mises(S: np.ndarray) -> np.ndarray:
    """Von Mises stress of rows ``sxx, syy, szz, sxy, s2, s3`` (the shear order does not matter)."""
    sxx, syy, szz, sxy, s2, s3 = S.T
    return np.sqrt(0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2) + 3 * (sxy**2 + s2**2 + s3**2))


def ccx_responses(deck: Path) -> dict[str, float]:
    """Responses of a CalculiX run from its ``.dat`` and ``.frd`` files (beside ``deck``).

    From the ``.dat``: ``max_displacement`` (largest ``|u|`` over the printed
    nodes), ``max_mises`` (largest von Mises stress over the printed
    integration points), ``mass`` (a ``TOTALS=ONLY`` ``EMAS`` print) and
    ``freq_1`` ... (cycles per time of a frequency step), each where the deck
    prints it. From the ``.frd`` (``*NODE FILE`` / ``*EL FILE``, last step):
    ``max_displacement`` where the ``.dat`` has none, and ``max_mises_nodal``
    (von Mises of the stresses CalculiX extrapolates to the nodes).

    Raises
    ------
    SolverError
        ``no_responses`` when neither file is there or they print none of them.
    """
    dat, frd = Path(deck).with_suffix(".dat"), Path(deck).with_suffix(".frd")
    if not dat.is_file() and not frd.is_file():
        raise SolverError(f"no {dat.name} or {frd.name} beside {Path(deck).name}: did the solver run?",
                          code="no_responses")
    blocks = _dat_blocks(dat.read_text(errors="replace")) if dat.is_file() else {}
    nodal = _frd_blocks(frd.read_text(errors="replace")) if frd.is_file() else {}
    out: dict[str, float] = {}
    U = blocks.get("displacements")
    if U is not None and U.shape[1] >= 4:
        out["max_displacement"] = float(np.linalg.norm(U[:, 1:4], axis=1).max())
    S = blocks.get("stresses")
    if S is not None and S.shape[1] >= 8:
        out["max_mises"] = float(_mises(S[:, 2:8]).max())
    D = nodal.get("DISP")
    if "max_displacement" not in out and D is not None and D.shape[1] >= 4:
        out["max_displacement"] = float(np.linalg.norm(D[:, 1:4], axis=1).max())
    N = nodal.get("STRESS")
    if N is not None and N.shape[1] >= 7:
        out["max_mises_nodal"] = float(_mises(N[:, 1:7]).max())
    M = blocks.get("total mass")
    if M is not None:
        out["mass"] = float(M[0, 0])
    E = blocks.get("E I G E N V A L U E   O U T P U T")
    if E is not None:
        col = 4 if E.shape[1] >= 6 else 3  # cyclic runs lead with the nodal diameter
        for k, f in enumerate(E[:, col], start=1):
            out[f"freq_{k}"] = float(f)
    if not out:
        raise SolverError(f"{dat.name} and {frd.name} hold no displacements, stresses, mass or frequencies",
                          code="no_responses")
    return out


def load_response(what: str) -> Response:
    """The response reader: ``"ccx"``, or a Python file defining ``response(deck) -> dict``.

    Raises
    ------
    SolverError
        ``invalid_response`` for a file that is missing, does not import, or has no ``response``.
    """
    return load_reader(what)[0]


def load_reader(what: str) -> tuple[Response, Callable[[Path], dict[str, object]] | None]:
    """The response reader and the file's gradient: ``(response, gradient)``.

    ``gradient`` is the file's ``gradient(deck) -> {name: (n, 3) array}`` when
    it defines one, else None (always for ``ccx``).

    Raises
    ------
    SolverError
        As :func:`load_response`.
    """
    if what == "ccx":
        return ccx_responses, None
    path = Path(what)
    if not path.is_file():
        raise SolverError(f"--response {what!r}: no such file (or 'ccx' for the built-in reader)",
                          code="invalid_response")
    spec = importlib.util.spec_from_file_location(f"tetmorph_response_{path.stem}", path)
    if spec is None or spec.loader is None:
        raise SolverError(f"--response {what!r}: not a Python file", code="invalid_response")
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception as e:  # the user's file: any error it raises is theirs, named here
        raise SolverError(f"--response {what!r} does not import: {type(e).__name__}: {e}",
                          code="invalid_response") from e
    fn = getattr(module, "response", None)
    if not callable(fn):
        raise SolverError(f"--response {what!r} defines no function response(deck)", code="invalid_response")
    grad = getattr(module, "gradient", None)
    return fn, grad if callable(grad) else None


def _command(template: str, deck: Path, row: int) -> list[str]:
    words = shlex.split(template)
    subs = {"{stem}": deck.stem, "{deck}": str(deck), "{dir}": str(deck.parent), "{i}": str(row)}
    out = []
    for w in words:
        for k, v in subs.items():
            w = w.replace(k, v)
        out.append(w)
    return out


def check_solver(template: str) -> None:
    """Refuse a solver command whose program is not found, before any row is morphed."""
    words = shlex.split(template)
    if not words:
        raise SolverError("--solver is empty", code="solver_not_found")
    if shutil.which(words[0]) is None:
        raise SolverError(f"solver command {words[0]!r} not found on PATH", code="solver_not_found",
                          command=words[0])


def _solve(row: StudyRow, template: str, response: Response, timeout: float,
           cancelled: Callable[[], bool] | None = None) -> None:
    """Run the solver on the row's deck and read its responses into ``row``.

    The run is killed past ``timeout`` seconds (``timeout``), or within
    ``_POLL_S`` of ``cancelled()`` answering true (``cancelled``).
    """
    assert row.deck is not None
    deck = Path(row.deck).resolve()
    t0 = time.perf_counter()
    deadline = time.monotonic() + timeout
    with subprocess.Popen(_command(template, deck, row.row), cwd=deck.parent, stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True) as proc:
        while True:
            try:
                out, err = proc.communicate(timeout=max(0.0, min(_POLL_S, deadline - time.monotonic())))
                break
            except subprocess.TimeoutExpired:
                stop = "cancelled" if cancelled is not None and cancelled() else None
                if stop is None and time.monotonic() >= deadline:
                    stop = "timeout"
                if stop is None:
                    continue
                proc.kill()
                proc.communicate()
                row.solver_s, row.status = time.perf_counter() - t0, stop
                row.message = f"stopped after {timeout:g} s" if stop == "timeout" else "cancelled"
                return
    row.solver_s = time.perf_counter() - t0
    read_run(row, deck, proc.returncode, out + err, response)


def read_run(row: StudyRow, deck: Path, returncode: int, log: str, response: Response) -> None:
    """A finished solver run into ``row``: its log beside the deck, its status, its responses.

    ``solver_failed`` for a non-zero exit or an ``*ERROR`` line in its output;
    ``response_failed`` when the reader raises; else ``ok`` with the responses.
    """
    (deck.parent / f"{deck.stem}.solver.log").write_text(log)
    errors = [ln.strip() for ln in log.splitlines() if "*ERROR" in ln]
    if returncode != 0 or errors:
        row.status = "solver_failed"
        row.message = (errors[0] if errors else f"exit code {returncode}")[:300]
        return
    try:
        got = response(deck)
        row.responses = {str(k): float(v) for k, v in dict(got).items()}
    except Exception as e:  # a user's reader may raise anything: the row records it
        row.status, row.message = "response_failed", f"{type(e).__name__}: {e}"[:300]
        return
    row.status = "ok"


def morph_rows(mesh: Mesh, deformer: Deformer, shapes: Shapes, plan: Plan, *, output: str,
               file_format: str | None = None, block: int = BLOCK, inversion: str | None = "reject",
               cancelled: Callable[[], bool] | None = None, nastran_large: bool = False) -> list[StudyRow]:
    """Morph every plan row and write its deck: the rows of a study, not solved yet.

    Parameters
    ----------
    mesh, deformer, shapes, plan
        As for :func:`~solver.workflows.doe.run_doe`.
    output : str
        Deck path per row; ``{i}`` is the plan row (from 1).
    file_format : str, optional
        meshio format name of the decks (default: the extension).
    block, inversion, cancelled
        As for :func:`~solver.workflows.doe.run_doe` (default policy ``reject``).
    nastran_large : bool
        As for :func:`~solver.workflows.doe.deck_writer`.

    Returns
    -------
    list of StudyRow
        In plan order; rows that are not ``ok`` say why in ``message``.
    """
    result = run_doe(deformer, shapes, plan, block=block, output=deck_writer(mesh, output, file_format, nastran_large,
                                                                             flatten=is_assembly(mesh)),
                     inversion=inversion, cancelled=cancelled)
    return study_rows(result)


def study_rows(result: DoeResult) -> list[StudyRow]:
    """The rows of a study from the morphs of its plan; rows that are not ``ok`` say why, unsolved."""
    rows = []
    for v in result.variants:
        r = StudyRow(v.row, v.parameters, v.status, v.inverted, v.min_scaled_jacobian, v.max_displacement, v.file)
        if not (v.status == "ok" and v.file is not None):
            r.message = "not solved: the morph was " + v.status
        rows.append(r)
    return rows


def solve_row(row: StudyRow, solver: str, response: Response, timeout: float = DEFAULT_TIMEOUT_S,
              cancelled: Callable[[], bool] | None = None) -> None:
    """Run the solver on a morphed row's deck and read its responses into ``row`` (a no-op for other rows).

    Parameters
    ----------
    row : StudyRow
        A row of :func:`morph_rows`; only an ``ok`` row with a deck is solved.
    solver : str
        The command, as for :func:`run_study`.
    response : callable
        ``response(deck) -> dict``.
    timeout : float
        Seconds the run may take; then it is killed and the row is ``timeout``.
    cancelled : callable, optional
        Asked while the solver runs; when it answers true the run is killed
        and the row is ``cancelled``, with no log or responses read.
    """
    if row.status == "ok" and row.deck is not None:
        _solve(row, solver, response, timeout, cancelled)


def run_study(mesh: Mesh, deformer: Deformer, shapes: Shapes, plan: Plan, *, output: str, solver: str,
              response: Response, timeout: float = DEFAULT_TIMEOUT_S, block: int = BLOCK,
              inversion: str | None = "reject", progress: Callable[[StudyRow], None] | None = None,
              nastran_large: bool = False) -> list[StudyRow]:
    """Morph every plan row, write its deck, run the solver on it and read its responses.

    Parameters
    ----------
    mesh, deformer, shapes, plan
        As for :func:`~solver.workflows.doe.run_doe`.
    output : str
        Deck path per row; ``{i}`` is the plan row (from 1).
    solver : str
        The command (``{stem}``, ``{deck}``, ``{dir}``, ``{i}`` substituted), run in the deck's folder.
    response : callable
        ``response(deck) -> dict`` (:func:`load_response`).
    timeout : float
        Seconds per solver run.
    inversion : str, optional
        The morph's inversion policy (default ``reject``: an inverting row is not solved).
    progress : callable, optional
        Called with each row when it is done.
    nastran_large : bool
        As for :func:`~solver.workflows.doe.deck_writer`.

    Returns
    -------
    list of StudyRow
        In plan order.
    """
    check_solver(solver)
    rows = morph_rows(mesh, deformer, shapes, plan, output=output, block=block, inversion=inversion,
                      nastran_large=nastran_large)
    for r in rows:
        solve_row(r, solver, response, timeout)
        if progress is not None:
            progress(r)
    return rows


def write_table(rows: list[StudyRow], shapes: tuple[str, ...], path: str | os.PathLike[str]) -> None:
    """The study table (CSV): row, parameters, status, mesh figures, solver time, every response, message."""
    names = sorted({k for r in rows for k in r.responses})
    fields = ["row", *shapes, "status", "inverted", "min_scaled_jacobian", "max_displacement_morph", "solver_s",
              *names, "deck", "message"]

    table = [{"row": r.row, **r.parameters, "status": r.status, "inverted": r.inverted,
              "min_scaled_jacobian": r.min_scaled_jacobian, "max_displacement_morph": r.max_displacement,
              "solver_s": r.solver_s, **r.responses, "deck": r.deck, "message": r.message} for r in rows]
    write_rows(path, fields, table)
