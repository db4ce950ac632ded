"""A study on a Ray cluster: the morphs on actors, then one Ray task per solver run.

The rows are morphed by :func:`~solver.workflows.ray_engine.run_doe_ray`'s
actors. Each task receives its deck's bytes, writes them into a private folder of
its worker, runs the solver command there with the time limit, and returns
every file the run left (its outputs and the log) as bytes; the driver
writes them beside the deck and reads the responses itself, so a user's
Python reader runs where the study was started and no shared volume is
needed for the solver's files. A task whose worker dies (killed, out of
memory, node lost) is run again by Ray, up to :data:`MAX_ATTEMPTS` times;
only a finished attempt's files are written, so a row is never half
written. The decks are bit-identical to a single-process ``tetmorph study``
(they are ``run_doe_ray``'s), and so are the solver's files when the solver
is deterministic.

Nothing here imports Ray before a run starts.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..errors import SolverError
from ..mesh import Mesh
from .doe import BLOCK
from .plan import Plan
from .ray_engine import connect, run_doe_ray
from .study import DEFAULT_TIMEOUT_S, Response, StudyRow, _command, check_solver, read_run, study_rows

__all__ = ["run_study_ray", "cmd_study_ray", "MAX_ATTEMPTS"]

#: Attempts of one solver run (a lost worker) before its row is recorded as ``solver_lost``.
MAX_ATTEMPTS = 3


def _run_in_worker(deck_name: str, deck: bytes, template: str, row: int, timeout: float) -> dict[str, Any]:
    """One solver run in a private folder of the worker: every file it leaves, as bytes."""
    with tempfile.TemporaryDirectory(prefix="tetmorph-study-") as tmp:
        path = Path(tmp) / deck_name
        path.write_bytes(deck)
        t0 = time.perf_counter()
        try:
            out = subprocess.run(_command(template, path, row), cwd=tmp, capture_output=True, text=True,
                                 timeout=timeout)
        except subprocess.TimeoutExpired:
            return {"timeout": True, "seconds": time.perf_counter() - t0, "files": {}}
        files = {p.relative_to(tmp).as_posix(): p.read_bytes() for p in Path(tmp).rglob("*")
                 if p.is_file() and p != path}
        return {"timeout": False, "seconds": time.perf_counter() - t0, "returncode": out.returncode,
                "log": out.stdout + out.stderr, "files": files}


def run_study_ray(mesh: Mesh, spec: dict[str, Any], shapes_doc: dict[str, Any], plan: Plan, *, output: str,
                  solver: str, response: Response, timeout: float = DEFAULT_TIMEOUT_S, block: int = BLOCK,
                  inversion: str | None = "reject", actors: int = 2, address: str | None = None,
                  progress: Callable[[StudyRow], None] | None = None, nastran_large: bool = False) -> list[StudyRow]:
    """:func:`~solver.workflows.study.run_study` on Ray: the morphs on actors, each solver run a task.

    Parameters
    ----------
    mesh, spec, shapes_doc, plan
        As for :func:`~solver.workflows.ray_engine.run_doe_ray`.
    output : str
        Deck path per row (``{i}`` the plan row) on a location the driver and the actors reach.
    solver, response, timeout, inversion
        As for :func:`~solver.workflows.study.run_study`.
    block, actors, address, nastran_large
        As for :func:`~solver.workflows.ray_engine.run_doe_ray`.
    progress : callable, optional
        Called with each row when it is done (in the order the runs finish).

    Returns
    -------
    list of StudyRow
        In plan order.
    """
    check_solver(solver)
    ray, _ = connect(address)
    result = run_doe_ray(mesh, spec, shapes_doc, plan, output=output, block=block, inversion=inversion,
                         actors=actors, nastran_large=nastran_large)
    rows = study_rows(result)
    task = ray.remote(num_cpus=1, max_retries=MAX_ATTEMPTS - 1, retry_exceptions=False)(_run_in_worker)
    pending = {}
    for r in rows:
        if r.status == "ok" and r.deck is not None:
            deck = Path(r.deck)
            pending[task.remote(deck.name, deck.read_bytes(), solver, r.row, timeout)] = r
    while pending:
        ready, _ = ray.wait(list(pending), num_returns=1)
        for ref in ready:
            r = pending.pop(ref)
            try:
                got = ray.get(ref)
            except ray.exceptions.RayError as e:  # the worker died on every attempt, or the task failed
                r.status, r.message = "solver_lost", f"{type(e).__name__} after {MAX_ATTEMPTS} attempts"[:300]
            else:
                _store(r, got, response, timeout)
            if progress is not None:
                progress(r)
    return rows


def _store(row: StudyRow, got: dict[str, Any], response: Response, timeout: float) -> None:
    """Write a finished run's files beside the row's deck and read its responses (the driver's side)."""
    assert row.deck is not None
    deck = Path(row.deck).resolve()
    row.solver_s = float(got["seconds"])
    if got["timeout"]:
        row.status, row.message = "timeout", f"stopped after {timeout:g} s"
        return
    for name, data in got["files"].items():
        target = deck.parent / name
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(data)
    read_run(row, deck, int(got["returncode"]), str(got["log"]), response)


def cmd_study_ray(args: argparse.Namespace) -> int:
    """``tetmorph study --engine ray``: the table ``tetmorph study`` writes, the rows on Ray."""
    from ..documents import load_json
    from ..io import read_mesh
    from .commands import _plan_for
    from .study import load_response, write_table

    plan = _plan_for(args, "out/{i}/deck.inp")
    if args.timeout <= 0:
        raise SolverError(f"--timeout must be > 0 seconds, got {args.timeout:g}", code="usage")
    check_solver(args.solver)
    response = load_response(args.response)
    spec = load_json(args.spec, "SPEC")
    shapes_doc = load_json(args.shapes, "SHAPES")
    mesh = read_mesh(args.mesh, args.format)
    ray, started = connect(args.address)

    def progress(r: StudyRow) -> None:
        print(f"row {r.row}: {r.status}" + (f" in {r.solver_s:.1f} s" if r.solver_s is not None else "")
              + (f"  ({r.message})" if r.message else ""), file=sys.stderr)

    try:
        rows = run_study_ray(mesh, spec, shapes_doc, plan, output=args.output, solver=args.solver,
                             response=response, timeout=args.timeout, block=args.block, inversion=args.inversion,
                             actors=args.actors, progress=progress, nastran_large=args.nastran_large)
    finally:
        if started:
            ray.shutdown()
    write_table(rows, tuple(rows[0].parameters) if rows else (), args.table)
    ok = sum(r.status == "ok" for r in rows)
    print(f"{ok} of {len(rows)} rows solved on Ray; table {args.table}", file=sys.stderr)
    return 0 if ok == len(rows) else 1
