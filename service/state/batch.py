"""Batches of plan rows on a session: the work of ``POST /v1/sessions/{id}/batch``.

Engine ``local`` solves on this replica's factorization of the session, one
block of rows at a time under the session's lock, so interactive MOVEs get in
between blocks; each block is one :func:`~solver.workflows.doe.run_doe` call
over the rows ``[k * block, (k + 1) * block)``, which is the block the
single-process ``tetmorph doe`` solves, so every deck is the one it writes.
Engine ``ray`` hands the plan to :func:`solver.workflows.ray_engine.run_doe_ray`
(actors on the cluster of ``TETMORPH_RAY_ADDRESS`` write the decks into the
job's folder of the data directory).

Decks go into one zip, ``{stem}_{row}.{ext}`` and ``summary.csv``, whose size
is capped (``TETMORPH_BATCH_MAX_RESULT_MB``). A failed or cancelled batch
leaves no file behind.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import re
import shutil
import tempfile
import threading
import time
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from solver.deform.deformer import Deformer, DeformResult
from solver.errors import SpecError
from solver.io import write_mesh
from solver.mesh import Mesh
from solver.workflows.doe import DoeResult, Variant, doe_basis, run_doe, write_summary
from solver.workflows.plan import Plan, parse_plan, plan_table, plan_values
from solver.workflows.shapes import Shapes, parse_shapes, variant_move

from ..errors import ServiceError
from .jobs import Job

__all__ = ["plan_of", "check_plan", "DeckZip", "sub_plan", "renumber", "summary_counts", "job_folder",
           "clear_jobs", "sweep_job_files", "sweep_dead_servers", "process_started"]


def plan_of(plan: Any, max_rows: int) -> Plan:
    """The plan of a request: ``{columns, rows}`` or CSV text (delimiter as ``tetmorph doe`` reads it).

    Raises
    ------
    ServiceError
        422 ``too_many_rows`` above ``max_rows``.
    SpecError
        ``empty_plan``, ``invalid_plan`` naming the row, its line and the column (or the line the
        CSV reader could not split).
    """
    if isinstance(plan, str):
        table = plan_table(plan.lstrip("\ufeff"))
        if len(table) < 2:
            raise SpecError("the plan needs a header of shape names and one row per variant", code="empty_plan",
                            field="plan")
        body = table[1:]
        _limit(len(body), max_rows)
        return parse_plan([row for _, row in body], table[0][1], [k for k, _ in body], text=True)
    _limit(len(plan.rows), max_rows)
    return parse_plan(plan.rows, plan.columns)


def _limit(rows: int, max_rows: int) -> None:
    if rows > max_rows:
        raise ServiceError("too_many_rows", f"the plan has {rows} rows; a batch takes at most {max_rows} "
                           "(TETMORPH_BATCH_MAX_ROWS): split it", field="plan", rows=rows, limit=max_rows)


def check_plan(deformer: Deformer, shapes_doc: dict[str, Any], plan: Plan) -> Shapes:
    """Parse the shapes and every row's variant MOVE before anything is solved (errors name shape or row)."""
    shapes = parse_shapes(shapes_doc, deformer)
    theta = plan_values(plan, shapes)
    for i in range(plan.rows):
        variant_move(deformer, shapes, theta[i], plan.where(i))
    return shapes


def sub_plan(plan: Plan, start: int, stop: int) -> Plan:
    """Rows ``[start, stop)`` of a plan (their file lines kept)."""
    lines = plan.lines[start:stop] if plan.lines is not None else None
    return Plan(plan.columns, plan.values[start:stop], lines)


def renumber(v: Variant, start: int) -> Variant:
    """A variant of a sub-plan numbered as a row of the whole plan."""
    return dataclasses.replace(v, row=v.row + start)


def summary_counts(result: DoeResult) -> dict[str, Any]:
    """Variants by status, and the timings."""
    counts = {k: sum(1 for v in result.variants if v.status == k) for k in ("ok", "rejected", "conflict")}
    return {"rows": result.rows, **counts, "timings": {k: round(float(v), 3) for k, v in result.timings.items()}}


class DeckZip:
    """The zip a batch answers: decks as they are written, then ``summary.csv``; at most ``limit`` bytes.

    Parameters
    ----------
    path : Path
    mesh : Mesh
        The session's mesh as read (a deck in its own format keeps every byte but the node coordinates).
    stem, ext, file_format : str
        Deck names ``{stem}_{row}{ext}``, and the meshio format.
    limit : int
        Bytes; :meth:`add` raises 422 ``result_too_large`` above.
    """

    def __init__(self, path: Path, mesh: Mesh, stem: str, ext: str, file_format: str, limit: int) -> None:
        self.path, self.mesh, self.stem, self.ext, self.format, self.limit = path, mesh, stem, ext, file_format, limit
        self._fh = open(path, "wb")  # noqa: SIM115 - closed by close()
        self.zip = zipfile.ZipFile(self._fh, "w", zipfile.ZIP_DEFLATED, compresslevel=1)
        self.tmp = Path(tempfile.mkdtemp(prefix="tetmorph-batch-", dir=path.parent))
        # A cancelled batch is discarded from the event loop while its block in flight may still be
        # writing a deck in a solve thread: the lock orders the two, and a discarded zip takes no more.
        self._lock = threading.RLock()
        self._discarded = False

    def name(self, row: int) -> str:
        """The deck's name in the zip."""
        return f"{self.stem}_{row}{self.ext}"

    def _check(self) -> None:
        size = self._fh.tell()
        if size > self.limit:
            raise ServiceError("result_too_large", f"the batch's zip passed {self.limit} bytes "
                               "(TETMORPH_BATCH_MAX_RESULT_MB); split the plan", bytes=size, limit=self.limit)

    def writer(self) -> Callable[[int, DeformResult], str]:
        """An ``output`` callback of :func:`~solver.workflows.doe.run_doe` adding each deck."""

        def out(row: int, res: DeformResult) -> str:
            name = self.name(row)
            with self._lock:
                if self._discarded:  # cancelled meanwhile: nothing more is written
                    return name
                f = self.tmp / name
                written = write_mesh(self.mesh, res.V, f, self.format)
                included = [Path(x) for x in written.files if Path(x) != f]
                if not included:
                    self.add_file(f, name)
                    return name
                # a deck with the files it includes: each row in a folder of its own, the tree kept
                folder = f"{self.stem}_{row}"
                for x in included:
                    self.add_file(x, f"{folder}/{x.relative_to(self.tmp).as_posix()}")
                self.add_file(f, f"{folder}/{name}")
            return f"{folder}/{name}"

        return out

    def add_file(self, f: Path, name: str) -> None:
        """Add a written deck and remove it (dropped when the zip was discarded)."""
        with self._lock:
            if self._discarded:
                f.unlink(missing_ok=True)
                return
            self.zip.write(f, arcname=name)
            f.unlink()
            self._check()

    def finish(self, result: DoeResult) -> None:
        """Add ``summary.csv`` and close (nothing when the zip was discarded)."""
        with self._lock:
            if self._discarded:
                return
            f = self.tmp / "summary.csv"
            write_summary(result, f)
            self.add_file(f, "summary.csv")
            self.close()

    def close(self) -> None:
        """Close the zip (idempotent) and remove the temporary folder."""
        with self._lock:
            try:
                if not self._fh.closed:
                    try:
                        self.zip.close()
                    finally:
                        self._fh.close()
            finally:
                shutil.rmtree(self.tmp, ignore_errors=True)

    def discard(self) -> None:
        """Close and remove everything (a failed or cancelled batch), after a deck being written."""
        with self._lock:
            self._discarded = True
            try:
                self.close()
            finally:
                self.path.unlink(missing_ok=True)


def solve_block(deformer: Deformer, shapes: Shapes, plan: Plan, start: int, block: int, inversion: str | None,
                out: Callable[[int, DeformResult], str], job: Job,
                bases: dict[int, Any] | None = None) -> list[Variant]:
    """One block of rows (a thread's work): run_doe over the sub-plan, numbered as rows of the whole plan.

    ``bases`` keeps the interior column basis of the plan's first block per deformer
    (:func:`~solver.workflows.doe.doe_basis`), built at the first block, so the
    blocks solve as in one ``tetmorph doe`` run; a deformer rebuilt meanwhile builds its own.
    """
    part = sub_plan(plan, start, min(start + block, plan.rows))

    def output(row: int, res: DeformResult) -> str:
        return out(row + start, res)

    if bases is None:  # no cache: the basis of the whole plan's first block all the same
        basis = doe_basis(deformer, shapes, plan, block)
    else:
        if id(deformer) not in bases or bases[id(deformer)][0] is not deformer:
            bases.clear()
            bases[id(deformer)] = (deformer, doe_basis(deformer, shapes, plan, block))
        basis = bases[id(deformer)][1]
    r = run_doe(deformer, shapes, part, block=block, output=output, inversion=inversion,
                cancelled=job.stop.is_set, basis=basis)
    return [renumber(v, start) for v in r.variants]


def job_folder(data_dir: Path, replica: str, job_id: str) -> Path:
    """Where one replica keeps a job's files (``jobs/<replica>/``, created)."""
    d = Path(data_dir) / "jobs" / "".join(c if c.isalnum() or c in "._-" else "_" for c in replica)
    d.mkdir(parents=True, exist_ok=True)
    return d / job_id


def clear_jobs(data_dir: Path, replica: str) -> None:
    """Remove what a previous process of this replica left in its jobs folder (jobs live in memory)."""
    d = Path(data_dir) / "jobs" / "".join(c if c.isalnum() or c in "._-" else "_" for c in replica)
    if d.is_dir():
        shutil.rmtree(d, ignore_errors=True)


def sweep_job_files(data_dir: Path, older_than_s: float, now: float | None = None) -> list[str]:
    """Remove job files no live job can own, whatever replica wrote them: untouched for ``older_than_s``.

    A running batch writes its zip as it goes and a finished one's zip is removed when the job
    expires, so a file older than the jobs' keep time belongs to a process that died (kill -9, a
    replica gone for good, a replica id that is new at every start). Returns what was removed.
    """
    now = time.time() if now is None else now
    root = Path(data_dir) / "jobs"
    removed: list[str] = []
    if not root.is_dir():
        return removed
    for folder in [d for d in root.iterdir() if d.is_dir()]:
        for entry in list(folder.iterdir()):
            try:
                newest = max([entry.stat().st_mtime] + [f.stat().st_mtime for f in entry.rglob("*")]
                             if entry.is_dir() else [entry.stat().st_mtime])
            except OSError:
                continue  # removed meanwhile
            if now - newest > older_than_s:
                if entry.is_dir():
                    shutil.rmtree(entry, ignore_errors=True)
                else:
                    entry.unlink(missing_ok=True)
                removed.append(f"{folder.name}/{entry.name}")
        with contextlib.suppress(OSError):
            folder.rmdir()  # only when empty
    return removed


#: Seconds by which a process must have started after its folder was last written to be another process
#: that reuses the folder's PID (the boot time the start is counted from is known to the second).
PID_REUSE_MARGIN_S = 2.0


def _folder_name(replica: str) -> str:
    return "".join(c if c.isalnum() or c in "._-" else "_" for c in replica)


def process_started(pid: int) -> float | None:
    """When process ``pid`` started (seconds since the epoch), or None when that cannot be read."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
        boot = next(float(line.split()[1]) for line in Path("/proc/stat").read_text().splitlines()
                    if line.startswith("btime "))
        return boot + int(stat[19]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, StopIteration):
        pass
    try:  # no /proc (macOS): psutil where it is installed
        import psutil

        return float(psutil.Process(pid).create_time())
    except Exception:  # noqa: BLE001 - not installed, gone, or not ours to read: unknown
        return None


def _runs(pid: int) -> bool:
    """Whether process ``pid`` runs (a zombie, ended and not reaped, does not)."""
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, OverflowError):  # none, or a number no PID can be
        return False
    except OSError:  # another user's process
        pass
    try:
        return Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0] not in ("Z", "X")
    except (OSError, IndexError):
        return True


def _last_written(folder: Path) -> float:
    times = [folder.stat().st_mtime]
    for f in folder.rglob("*"):
        with contextlib.suppress(OSError):
            times.append(f.lstat().st_mtime)
    return max(times)


def _may_own(pid: int, written: float) -> bool:
    """Whether process ``pid`` may be the one that last wrote a folder at ``written``."""
    if not _runs(pid):
        return False
    started = process_started(pid)  # unknown: it may be the owner
    return started is None or started <= written + PID_REUSE_MARGIN_S


def sweep_dead_servers(data_dir: Path, host: str) -> list[str]:
    """Remove the job folders that servers of ``host`` left when they stopped, whatever their age.

    A single server's replica id is ``<host>-<pid>`` (the default :attr:`~service.settings.Settings.replica_id`),
    so a new process never clears its predecessor's folder, and :func:`sweep_job_files` would wait for the jobs'
    keep time. A folder ``jobs/<host>-<pid>`` goes when no process ``pid`` runs, or when the process that has
    that PID now started after the folder was last written (the PID was reused). Only for a server whose data
    directory is its own: replicas sharing a store (and the data directory) on other hosts have PIDs this host
    cannot judge. Returns the folders removed.
    """
    root = Path(data_dir) / "jobs"
    if not root.is_dir():
        return []
    pattern = re.compile(re.escape(_folder_name(host)) + r"-(\d+)")
    removed: list[str] = []
    for folder in sorted(root.iterdir()):
        m = pattern.fullmatch(folder.name)
        if m is None or not folder.is_dir() or int(m.group(1)) == os.getpid():
            continue
        try:
            if _may_own(int(m.group(1)), _last_written(folder)):
                continue
        except OSError:
            continue  # removed meanwhile
        shutil.rmtree(folder, ignore_errors=True)
        removed.append(folder.name)
    return removed


def remove_tree(path: str | os.PathLike[str]) -> None:
    """Remove a folder if there."""
    shutil.rmtree(path, ignore_errors=True)
