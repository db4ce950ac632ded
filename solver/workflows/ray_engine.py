"""DOE on a Ray cluster: actors each hold one factorization and solve blocks of plan rows.

:func:`run_doe_ray` is :func:`~solver.workflows.doe.run_doe` spread over Ray
actors (``pip install 'tetmorph[cluster]'``):

* the mesh, the SPEC, the shapes and the plan are put in the object store
  once (each node fetches them once);
* each actor (:class:`DoeWorker`) builds the precompute from them once, then
  solves blocks of rows, each block one :func:`run_doe` call over the rows
  ``[k * block, (k + 1) * block)`` -- the very block the single-process
  ``tetmorph doe`` stacks into one back-substitution, through the interior
  column basis of the plan's first block that each actor builds once as
  ``tetmorph doe`` does, so every deck and every summary value is
  bit-identical to it;
* decks are written by the actors into a private folder beside ``output``
  (a path every node reaches: a shared volume), one folder per attempt of a
  block; when the block's task returns, the driver renames them to their
  names. A block whose actor dies is solved again by another actor (Ray
  restarts the dead one from the object store) and its partial folder is
  removed, so no row is lost and none is written twice;
* the driver gathers the variants in plan order into one
  :class:`~solver.workflows.doe.DoeResult`.

Nothing here imports Ray before a run starts.
"""

from __future__ import annotations

import argparse
import collections
import hashlib
import os
import secrets
import shutil
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..deform.deformer import Deformer, DeformResult
from ..deform.positions import InteriorBasis
from ..errors import SolverError, SpecError
from ..mesh import Mesh
from .batch_memory import keep_freed_memory
from .doe import BLOCK, DoeResult, Variant, deck_writer, doe_basis, run_doe, write_summary
from .plan import Plan, plan_values, read_plan
from .shapes import parse_shapes, variant_move

__all__ = ["DoeWorker", "run_doe_ray", "connect", "add_ray_options", "cmd_doe_ray", "NAMESPACE", "MAX_ATTEMPTS"]

#: Ray namespace of the actors (a run's actors are named ``{name}-{k}`` there).
NAMESPACE = "tetmorph"
#: Attempts of one block before the run fails.
MAX_ATTEMPTS = 4
#: Restarts Ray gives an actor that died (it rebuilds its precompute from the object store).
MAX_RESTARTS = 3


def connect(address: str | None = None, **init: Any) -> tuple[Any, bool]:
    """Ray, connected to ``address`` (``None``: a local Ray of this machine); ``(ray, started_here)``.

    Raises
    ------
    SolverError
        ``missing_extra`` when Ray is not installed.
    """
    try:
        import ray
    except ImportError:
        raise SolverError("the Ray engine needs the cluster extra: pip install 'tetmorph[cluster]'",
                          code="missing_extra") from None
    if ray.is_initialized():
        return ray, False
    if address is None:  # a new Ray of this machine only: every server on the loopback address
        address = "local"
        init = {"_node_ip_address": "127.0.0.1", "include_dashboard": False, **init}
    ray.init(address=address, namespace=NAMESPACE, log_to_driver=False, **init)
    return ray, True


class DoeWorker:
    """A Ray actor's state: one deformer and the parsed shapes.

    Parameters
    ----------
    mesh : Mesh
    spec : dict
    shapes_doc : dict
        The SHAPES document.
    """

    def __init__(self, mesh: Mesh, spec: dict[str, Any], shapes_doc: dict[str, Any]) -> None:
        t0 = time.perf_counter()
        keep_freed_memory()  # an actor's process runs one batch
        self.deformer = Deformer(mesh, spec)
        self.shapes = parse_shapes(shapes_doc, self.deformer)
        self.setup_ms = 1e3 * (time.perf_counter() - t0)
        self._basis: tuple[tuple[int, int, bytes], InteriorBasis | None] | None = None

    def pid(self) -> int:
        """The actor's process id."""
        return os.getpid()

    def node(self) -> str:
        """The id of the Ray node the actor runs on."""
        import ray

        return str(ray.get_runtime_context().get_node_id())

    def info(self) -> dict[str, Any]:
        """Process id, set-up time and shape names."""
        return {"pid": os.getpid(), "setup_ms": self.setup_ms, "shapes": list(self.shapes.names)}

    def check(self, plan: Plan) -> dict[str, Any] | None:
        """Every row's variant MOVE parsed (nothing solved): None, or the first error's document."""
        try:
            theta = plan_values(plan, self.shapes)
            for i in range(plan.rows):
                variant_move(self.deformer, self.shapes, theta[i], plan.where(i))
        except SolverError as e:
            return e.to_dict()
        return None

    def basis(self, plan: Plan, block: int) -> InteriorBasis | None:
        """The interior column basis of the plan's first block (:func:`~solver.workflows.doe.doe_basis`), built once."""
        key = (plan.rows, block, hashlib.sha256(repr(plan.columns).encode() + plan.values.tobytes()).digest())
        if self._basis is None or self._basis[0] != key:
            self._basis = (key, doe_basis(self.deformer, self.shapes, plan, block))
        return self._basis[1]

    def solve(self, plan: Plan, start: int, block: int, output: str | None, file_format: str | None,
              inversion: str | None, quality: str, folder: str | None,
              nastran_large: bool = False) -> tuple[list[Variant], list[tuple[str, str]]]:
        """Rows ``[start, start + block)``: their variants, and ``(written, final)`` deck paths."""
        stop = min(start + block, plan.rows)
        part = Plan(plan.columns, plan.values[start:stop], plan.lines[start:stop] if plan.lines else None)
        files: list[tuple[str, str]] = []
        out = None
        if output is not None and folder is not None:
            os.makedirs(folder, exist_ok=True)
            write = deck_writer(self.deformer.mesh, os.path.join(folder, os.path.basename(output)), file_format,
                                nastran_large)

            def out(row: int, res: DeformResult) -> str:
                final = output.replace("{i}", str(row + start))
                files.append((str(write(row + start, res)), final))
                return final

        r = run_doe(self.deformer, self.shapes, part, block=block, output=out, inversion=inversion,
                    quality=quality, basis=self.basis(plan, block))
        return [Variant(**{**v.__dict__, "row": v.row + start}) for v in r.variants], files


def _lost_errors(ray: Any) -> tuple[type[BaseException], ...]:
    names = ("RayActorError", "ActorDiedError", "ActorUnavailableError", "WorkerCrashedError", "NodeDiedError",
             "ObjectLostError", "OwnerDiedError")
    return tuple(getattr(ray.exceptions, n) for n in names if hasattr(ray.exceptions, n))


def run_doe_ray(mesh: Mesh, spec: dict[str, Any], shapes_doc: dict[str, Any], plan: Plan, *,
                output: str | None = None, file_format: str | None = None, block: int = BLOCK,
                inversion: str | None = None, quality: str = "basic", actors: int = 2,
                address: str | None = None, progress: Callable[[int, int], None] | None = None,
                cancelled: Callable[[], bool] | None = None, name: str | None = None,
                num_cpus: float = 1.0, nastran_large: bool = False) -> DoeResult:
    """Morph every row of ``plan`` on Ray actors; the result :func:`run_doe` gives, bit for bit.

    Parameters
    ----------
    mesh, spec : Mesh, dict
        What each actor builds its precompute from.
    shapes_doc : dict
        The SHAPES document.
    plan : Plan
    output : str, optional
        Deck path pattern (``{i}`` the row) on a location every node reaches;
        None writes no decks.
    file_format : str, optional
    block : int
        Rows per stacked solve; the unit of work an actor takes.
    inversion, quality
        As :func:`run_doe`.
    actors : int
        Actors (each one factorization, ``num_cpus`` CPUs).
    address : str, optional
        Ray address when not connected yet (``None``: start a local Ray).
    progress : callable, optional
        ``progress(rows_done, rows_total)`` after each block (the actor that
        finished has its next block already).
    cancelled : callable, optional
        Asked between blocks; True stops the run (``cancelled`` in the result).
    name : str, optional
        The actors are ``{name}-{k}`` in namespace :data:`NAMESPACE` (default random).
    num_cpus : float
    nastran_large : bool
        As for :func:`~solver.workflows.doe.deck_writer`.

    Returns
    -------
    DoeResult
        ``timings`` adds ``setup_ms`` (the slowest actor's precompute),
        ``actors`` and ``retried_blocks``.

    Raises
    ------
    SpecError
        A plan column or row that is no valid variant, before anything is solved.
    SolverError
        ``ray_block_failed``: a block failed :data:`MAX_ATTEMPTS` times.
    """
    if isinstance(block, bool) or not isinstance(block, int) or block < 1:
        raise SpecError(f"block must be a positive integer, got {block!r}", code="invalid_plan", field="block")
    if isinstance(actors, bool) or not isinstance(actors, int) or actors < 1:
        raise SpecError(f"actors must be a positive integer, got {actors!r}", code="usage", field="actors")
    if output is not None and plan.rows > 1 and "{i}" not in output:
        raise SolverError("with several plan rows, the output needs '{i}' (the plan row)", code="usage")
    ray, _ = connect(address)
    t0 = time.perf_counter()
    name = name or f"doe-{secrets.token_hex(4)}"
    mesh_ref, spec_ref, shapes_ref, plan_ref = (ray.put(x) for x in (mesh, spec, shapes_doc, plan))
    remote = ray.remote(num_cpus=num_cpus, max_restarts=MAX_RESTARTS, max_task_retries=0)(DoeWorker)
    pool = [remote.options(name=f"{name}-{k}", namespace=NAMESPACE).remote(mesh_ref, spec_ref, shapes_ref)
            for k in range(min(actors, -(-plan.rows // block)))]
    tmp_root = (Path(os.path.dirname(os.path.abspath(output))) / f".tetmorph-{name}") if output else None
    lost = _lost_errors(ray)
    try:
        infos = ray.get([a.info.remote() for a in pool])
        error = ray.get(pool[0].check.remote(plan_ref))
        if error is not None:
            raise SpecError(error.get("message", "invalid plan"), code=error.get("code"),
                            **(error.get("details") or {}))
        todo: collections.deque[tuple[int, int]] = collections.deque((s, 0) for s in range(0, plan.rows, block))
        inflight: dict[Any, tuple[int, int, int, Path | None]] = {}
        idle = list(range(len(pool)))
        done: dict[int, list[Variant]] = {}
        rows_done = retried = 0
        stopped = False

        def submit() -> None:
            while idle and todo:
                k = idle.pop(0)
                start, attempt = todo.popleft()
                folder = tmp_root / f"{start}-{attempt}" if tmp_root is not None else None
                ref = pool[k].solve.remote(plan_ref, start, block, output, file_format, inversion, quality,
                                           None if folder is None else str(folder), nastran_large)
                inflight[ref] = (k, start, attempt, folder)

        while todo or inflight:
            if cancelled is not None and cancelled():
                stopped = True
                break
            submit()
            ready, _ = ray.wait(list(inflight), num_returns=1, timeout=1.0)
            for ref in ready:
                k, start, attempt, folder = inflight.pop(ref)
                try:
                    variants, files = ray.get(ref)
                except lost:
                    if folder is not None:
                        shutil.rmtree(folder, ignore_errors=True)  # whatever the dead attempt wrote
                    retried += 1
                    if attempt + 1 >= MAX_ATTEMPTS:
                        raise SolverError(f"rows {start + 1}..{min(start + block, plan.rows)} failed on "
                                          f"{MAX_ATTEMPTS} actors", code="ray_block_failed", row=start + 1) from None
                    todo.appendleft((start, attempt + 1))
                    idle.append(k)  # Ray restarts the actor; calls wait for it
                    continue
                except ray.exceptions.RayTaskError as e:
                    cause = e.as_instanceof_cause()
                    raise (cause if isinstance(cause, SolverError) else e) from None
                for written, final in files:
                    os.makedirs(os.path.dirname(os.path.abspath(final)), exist_ok=True)
                    os.replace(written, final)
                if folder is not None:
                    shutil.rmtree(folder, ignore_errors=True)
                done[start] = variants
                rows_done += len(variants)
                idle.append(k)
                submit()
                if progress is not None:
                    progress(rows_done, plan.rows)
    finally:
        for a in pool:
            ray.kill(a, no_restart=True)
        if tmp_root is not None:
            shutil.rmtree(tmp_root, ignore_errors=True)
    variants = [v for s in sorted(done) for v in done[s]]
    total_ms = 1e3 * (time.perf_counter() - t0)
    timings = {"total_ms": total_ms, "per_variant_ms": total_ms / max(len(variants), 1),
               "setup_ms": max(i["setup_ms"] for i in infos), "actors": float(len(pool)),
               "retried_blocks": float(retried)}
    return DoeResult(tuple(infos[0]["shapes"]), variants, plan.rows, stopped, block, timings)


def add_ray_options(parser: argparse.ArgumentParser) -> None:
    """``--engine``, ``--address`` and ``--actors`` of ``tetmorph doe``."""
    parser.add_argument("--engine", choices=["local", "ray"], default="local", help="local: this process; "
                        "ray: actors of a Ray cluster (the cluster extra), decks on a path every node reaches")
    parser.add_argument("--address", help="Ray address (ray://head:10001, head:6379 or auto); default: a local "
                        "Ray started for the run")
    parser.add_argument("--actors", type=int, default=2, help="Ray actors, each with one factorization (default 2)")


def cmd_doe_ray(args: argparse.Namespace) -> int:
    """``tetmorph doe --engine ray``: the decks and the summary ``tetmorph doe`` writes, from Ray actors."""
    from ..documents import load_json
    from ..io import read_mesh

    plan = read_plan(args.plan)
    spec = load_json(args.spec, "SPEC")
    shapes_doc = load_json(args.shapes, "SHAPES")
    mesh = read_mesh(args.mesh, args.format)
    ray, started = connect(args.address)
    try:
        result = run_doe_ray(mesh, spec, shapes_doc, plan, output=args.output, file_format=args.output_format,
                             block=args.block, inversion=args.inversion, actors=args.actors,
                             nastran_large=args.nastran_large)
    finally:
        if started:
            ray.shutdown()
    for v in result.variants:
        if v.status != "ok":
            print(f"row {v.row}: {v.status}, inverted={v.inverted}; no deck written", file=sys.stderr)
    write_summary(result, args.summary)
    t = result.timings
    print(f"{plan.rows} rows on {t['actors']:.0f} Ray actors (set-up {t['setup_ms']:.0f} ms each, "
          f"{t['retried_blocks']:.0f} blocks retried) in {t['total_ms']:.0f} ms; summary {args.summary}",
          file=sys.stderr)
    return 1 if any(v.status != "ok" for v in result.variants) else 0
