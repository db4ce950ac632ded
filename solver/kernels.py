"""Load what a first set-up needs ahead of use: the compiled core, the solver's modules, the document models.

The kernels are compiled when the project is installed (``tetmorph_core``,
C++ in ``src/core``, built by ``pip install``); nothing compiles at run
time. What a process still pays once is loading: the extension and MKL's
library, the solver's modules, and the document models (pydantic builds
each model's validator when its class is made; the members a first set-up
does not use, such as the edits, are built when a document first gives
them, :mod:`solver.documents.deferred`). :func:`load_kernels` pays it ahead
of the first set-up:

- the service calls it at start, before ``/ready`` answers ready, so no
  client's first session waits for it;
- a pipeline that sets up one mesh per process may call it while it reads
  its deck.

``benchmarks/bench_update.py`` reports its cost per process (``load``)
next to the peer's ``import igl``.

    python -m solver.kernels        # prints the seconds it took
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from collections.abc import Iterator
from typing import TextIO

__all__ = ["load_kernels", "announced", "loaded"]

_LOADED: list[float] = []  # the seconds load_kernels took, once it has run in this process


@contextlib.contextmanager
def announced(what: str, after_s: float = 1.0, stream: TextIO | None = None) -> Iterator[None]:
    """Say on standard error what is being done, once it has taken ``after_s`` seconds, and when it ends.

    Short work says nothing; a first use that compiles the kernels (minutes)
    or a cold load (a second or two) is never silent.

    Parameters
    ----------
    what : str
        ``"loading the solver's kernels"``.
    after_s : float
    stream : file, optional
        Default: ``sys.stderr``.
    """
    out = stream if stream is not None else sys.stderr
    done = threading.Event()
    said = threading.Event()
    t0 = time.perf_counter()

    def watch() -> None:
        if not done.wait(after_s):
            print(f"tetmorph: {what}...", file=out, flush=True)
            said.set()

    watcher = threading.Thread(target=watch, name="tm-announce", daemon=True)
    watcher.start()
    try:
        yield
    finally:
        done.set()
        watcher.join()
        if said.is_set():
            print(f"tetmorph: {what}: done in {time.perf_counter() - t0:.1f} s", file=out, flush=True)


def load_kernels(complete: bool = False) -> float:
    """Load the compiled core, MKL's library, the modules of a set-up and the document models.

    Parameters
    ----------
    complete : bool
        Also what only some documents use: the edits' modules and models, and the SPEC's and MOVE's
        members built on first use (:mod:`solver.documents.deferred`). A server that answers many
        documents (the service) pays it at start, so that no session does; a process that sets up
        one SPEC leaves it to that SPEC.

    Returns the seconds taken; cheap once a process has run it.
    """
    t0 = time.perf_counter()
    import tetmorph_core  # noqa: F401 - the compiled kernels

    from .deform import precompute  # noqa: F401 - the set-up's modules
    from .linalg import pardiso

    if pardiso.mkl_runtime() is not None:
        pardiso._library()  # PARDISO's entry point in MKL's library
    _document_models()
    if complete:
        _rarely_used()
    took = time.perf_counter() - t0
    _LOADED.append(took)
    return took


def loaded() -> bool:
    """Whether :func:`load_kernels` has run in this process."""
    return bool(_LOADED)


def _document_models() -> None:
    """The SPEC and MOVE models (pydantic and the models' validators are built on first use)."""
    from .constraints.move import parse_move
    from .constraints.spec import parse_spec

    spec = parse_spec({"selections": {"a": {"ids": [0]}, "b": {"ids": [1]}}, "fixed": ["a"], "handles": {"h": "b"}})
    parse_move({"handles": {"h": {"translation": [0, 0, 0]}}}, list(spec.handles), spec.names)



def _rarely_used() -> None:
    """The edits' modules, and every member of the SPEC and MOVE that is built on first use."""
    from .constraints import edit_values, resolve_edits  # noqa: F401 - the edits' entries, values, resolution
    from .documents.deferred import build
    from .documents.move import Move
    from .documents.spec import Spec

    build(Spec, Move)


if __name__ == "__main__":
    with announced("loading the solver's compiled kernels"):
        took = load_kernels()
    print(f"tetmorph solver loaded ({took:.2f} s)")
