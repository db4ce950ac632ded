"""The documents tetmorph reads and writes: their models, and JSON files on disk.

* :mod:`~solver.documents.numbers` -- the number types of every document (strict, finite, bounded by
  :mod:`solver.limits`);
* :mod:`~solver.documents.move` -- the MOVE document, as pydantic models. The library's
  :func:`~solver.constraints.move.parse_move` and the service's OpenAPI schema both use them, so a MOVE
  has one definition and is validated once;
* :mod:`~solver.documents.edits`, :mod:`~solver.documents.edit_moves` -- the daily edits' SPEC entries
  (``radius``, ``twist``, ``map``, ``offset``, ``lattice``, ``fillet``, ``distance``, ``angle``) and their
  MOVE parameters;
  :mod:`~solver.documents.geometry` the directions, boxes, axes and analytic geometry they name;
* :mod:`~solver.documents.report_record` -- the REPORT, as the frozen dataclass every update fills (no
  pydantic); :mod:`~solver.documents.report` builds its pydantic model from it, for the OpenAPI schema;
* :mod:`~solver.documents.deferred` -- the SPEC's and MOVE's members whose validators are made when a
  document first gives them (the edits, points, symmetries, targets, ...), so that a plain set-up
  builds only what it uses;
* :mod:`~solver.documents.validation` -- a model's validation errors as a :class:`~solver.errors.SpecError`
  naming the field;
* :mod:`~solver.documents.files` -- SPEC, MOVE and SHAPES files in, REPORTs out, for the command line.

The models import pydantic; this package's ``__init__`` does not, so ``import solver`` stays as light
as it was.
"""

from .files import dump_json, load_json

__all__ = ["load_json", "dump_json"]
