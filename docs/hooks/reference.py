"""MkDocs hook: reference pages generated from the code at build time, so they cannot disagree with it.

* ``reference/settings.md`` from :class:`service.settings.Settings` (every field, its
  ``TETMORPH_*`` variable, type, default and description), with the notes of
  :mod:`reference_text`;
* ``reference/errors.md`` from the codes of :mod:`service.errors` and :mod:`solver.errors` and
  from every code the ``solver`` and ``service`` packages raise, each with the HTTP status
  :func:`service.errors.status_of` gives it, its meaning and its fix;
* ``reference/rest.md`` from the app's OpenAPI document (one section per route);
* ``reference/documents.md`` from the pydantic models of SPEC, MOVE, REPORT and SHAPES
  (``solver/documents/``), and of the stream frame, batches, bounds and presets (``service/models/``);
* ``reference/formats.md`` from the measured table of ``service/format_table.py`` (``GET /v1/formats``);
* ``img/benchmark-update-ratio.svg`` from the tables of ``benchmarks.md`` (``docs/scripts/benchmark_plots.py``).

The pictures of real morphs are files of ``docs/img/``, rendered by ``make docs-img``
(``docs/scripts/pictures.py``).

A note or a meaning kept for a setting or a code that no longer exists is a warning, which
``mkdocs build --strict`` turns into an error.
"""

from __future__ import annotations

import ast
import functools
import json
import logging
import re
import sys
import tempfile
from pathlib import Path
from typing import Any

from mkdocs.structure.files import File, Files

sys.path.insert(0, str(Path(__file__).parent))
import reference_text as text  # noqa: E402 - beside this hook

log = logging.getLogger("mkdocs.hooks.reference")
ROOT = Path(__file__).resolve().parents[2]
BOUND_SIGNS = {"gt": ">", "ge": "≥", "lt": "<", "le": "≤"}
PLOT = "img/benchmark-update-ratio.svg"  # drawn from the tables of benchmarks.md
PAGES = ("reference/settings.md", "reference/errors.md", "reference/rest.md", "reference/documents.md",
         "reference/formats.md")


def on_files(files: Files, config: Any) -> Files:
    """Add the generated reference pages, and the plot of the benchmark tables, to the site."""
    for uri, make in zip(PAGES, (settings_page, errors_page, rest_page, documents_page, formats_page), strict=True):
        files.append(File.generated(config, uri, content=make()))
    sys.path.insert(0, str(ROOT / "docs" / "scripts"))
    import benchmark_plots

    page = Path(config["docs_dir"]) / "benchmarks.md"
    files.append(File.generated(config, PLOT, content=benchmark_plots.update_ratio_svg(page.read_text())))
    return files


# ---------------------------------------------------------------------------------------------- helpers

def cell(value: Any) -> str:
    """One table cell: a single line, pipes escaped."""
    return " ".join(str(value).split()).replace("|", "\\|")


def code(value: Any) -> str:
    """Inline code of a value, in a table cell."""
    s = " ".join(str(value).split()).replace("`", "'")
    return f"`{s}`" if s else ""


def table(header: list[str], rows: list[list[Any]]) -> str:
    """A Markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def stale(kind: str, names: set[str]) -> None:
    """Warn about hand-written entries whose setting or code is gone."""
    for name in sorted(names):
        log.warning("docs/hooks/reference_text.py: %s %r no longer exists in the code", kind, name)


# --------------------------------------------------------------------------------------------- settings

def settings_page() -> str:
    """The settings and environment variables."""
    from service.settings import Settings

    prefix = Settings.model_config.get("env_prefix", "")
    rows = []
    for name, f in Settings.model_fields.items():
        default = text.SETTING_DEFAULTS.get(name)
        if default is None:
            default = code(f.default) if f.default_factory is None else "computed at start"
        limits = ", ".join(f"{sign} {getattr(m, op)}" for m in f.metadata for op, sign in BOUND_SIGNS.items()
                           if type(m).__name__.lower() == op)
        kind = f.annotation.__name__ if isinstance(f.annotation, type) else str(f.annotation).replace("typing.", "")
        desc = f.description or ""
        if name in text.SETTING_NOTES:
            desc += " " + text.SETTING_NOTES[name]
        rows.append([code(prefix + name.upper()), code(name), code(kind) + (f" ({limits})" if limits else ""),
                     default, desc])
    stale("setting", set(text.SETTING_NOTES) - set(Settings.model_fields))
    return (
        "# Settings and environment variables\n\n"
        "Generated from `service/settings.py` when the site is built. Every setting of the service is an\n"
        f"environment variable `{prefix}` + its name in upper case, or an argument of\n"
        "`Settings(...)` / `create_app(data_dir=...)`; a list is comma separated\n"
        f"(`{prefix}API_KEYS=a,b`). The guide's [REST service](../guide/service.md) page says how they\n"
        "work together.\n\n## The service's settings\n\n"
        + table(["variable", "setting", "type", "default", "what it does"], rows)
        + "\n## Read by the solver\n\n"
        "These are read from the environment by the `solver` package (library, CLI and service alike),\n"
        "not by `Settings`.\n\n"
        + table(["variable", "what it does"], [[code(k), v] for k, v in text.SOLVER_ENVIRONMENT.items()])
    )


# ------------------------------------------------------------------------------------------- error codes

def _error_classes() -> dict[str, type]:
    import service.errors as sv
    import solver.errors as se

    names = {n: getattr(se, n) for n in se.__all__ if isinstance(getattr(se, n), type)}
    names["ServiceError"] = sv.ServiceError
    return names


def _message(node: ast.Call, service: bool) -> str:
    args = list(node.args) + [k.value for k in node.keywords if k.arg == "message"]
    arg = args[1] if service and len(args) > 1 else (args[0] if args and not service else None)
    if isinstance(arg, ast.Constant):
        return str(arg.value)
    if isinstance(arg, ast.JoinedStr):
        return "".join(v.value if isinstance(v, ast.Constant) else "…" for v in arg.values)
    return ""


def raised_codes() -> dict[str, dict[str, Any]]:
    """Every literal code a ``solver`` or ``service`` module raises: its exception types, modules, a message."""
    classes = _error_classes()
    found: dict[str, dict[str, Any]] = {}
    for path in sorted((ROOT / "solver").rglob("*.py")) + sorted((ROOT / "service").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.Call):
                continue
            f = node.func
            fname = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else ""
            if fname not in classes:
                continue
            service = fname == "ServiceError"
            lit = [k.value for k in node.keywords if k.arg == "code"]
            if service and node.args:
                lit.append(node.args[0])
            elif len(node.args) > 1:
                lit.append(node.args[1])
            for c in lit:
                if isinstance(c, ast.Constant) and isinstance(c.value, str):
                    entry = found.setdefault(c.value, {"types": set(), "modules": set(), "message": ""})
                    entry["types"].add(fname)
                    entry["modules"].add(path.relative_to(ROOT).as_posix())
                    entry["message"] = entry["message"] or _message(node, service)
    return found


def docstring_codes(doc: str) -> list[str]:
    """The codes a solver error's docstring lists after ``Codes:`` (parenthesised details left out)."""
    if "Codes:" not in doc:
        return []
    listed = re.sub(r"\([^)]*\)", "", doc.split("Codes:", 1)[1], flags=re.S)
    return re.findall(r"``(\w+)``", listed)


def error_codes() -> dict[str, dict[str, Any]]:
    """Every error code: defined in the two error modules or raised, with its statuses."""
    import service.errors as sv
    import solver.errors as se

    classes = _error_classes()
    codes = raised_codes()
    for name, cls in classes.items():
        if name != "ServiceError" and issubclass(cls, se.SolverError):
            entry = codes.setdefault(cls.default_code, {"types": set(), "modules": set(), "message": ""})
            entry["types"].add(name)
            entry["modules"].add("solver/errors.py")
            for c in docstring_codes(cls.__doc__ or ""):
                e = codes.setdefault(c, {"types": set(), "modules": set(), "message": ""})
                e["types"].add(name)
                e["modules"].add("solver/errors.py")
    for c in list(sv.CODE_STATUS) + ["store_unavailable"]:
        codes.setdefault(c, {"types": {"ServiceError"}, "modules": {"service/errors.py"}, "message": ""})
    for entry_code, entry in codes.items():
        statuses = set()
        for t in entry["types"]:
            cls = classes[t]
            e = cls(entry_code, "") if t == "ServiceError" else cls("", code=entry_code) \
                if t != "InversionError" else cls("", report={})
            statuses.add(503 if entry_code == "store_unavailable" else sv.status_of(e))
        entry["status"] = sorted(statuses)
    return codes


def errors_page() -> str:
    """Every error code with its HTTP status, meaning and fix."""
    import service.errors as sv

    codes = error_codes()
    bare = {c: s for s, c in sv.HTTP_CODES.items() if c not in codes}
    stale("error code", set(text.ERRORS) - set(codes) - set(bare))
    groups: dict[int, list[list[str]]] = {}
    for c in sorted(codes):
        e = codes[c]
        meaning, fix = text.ERRORS.get(c, (e["message"] or "", ""))
        where = ", ".join(f"`{m}`" for m in sorted(e["modules"]))
        types = ", ".join(f"`{t}`" for t in sorted(e["types"]))
        status = " / ".join(str(s) for s in e["status"])
        groups.setdefault(e["status"][0], []).append(
            [f"<span id=\"{c}\"></span>`{c}`", status, meaning, fix, f"{types} in {where}"])
    out = [text.ERRORS_INTRO]
    for status in sorted(groups):
        out.append(f"\n## {text.STATUS_TITLES.get(status, status)}\n\n")
        out.append(table(["code", "HTTP", "meaning", "fix", "type, module"], groups[status]))
    out.append("\n## Answers of a bare HTTP status\n\n"
               "Routing and protocol errors that no route raises itself carry the code of their status "
               "(`service.errors.HTTP_CODES`):\n\n")
    out.append(table(["code", "HTTP", "meaning", "fix"],
                     [[f'<span id="{c}"></span>`{c}`', s, *text.ERRORS.get(c, ("", ""))]
                      for c, s in sorted(bare.items(), key=lambda kv: kv[1])]))
    return "".join(out)


# ------------------------------------------------------------------------------------------------- REST

def _schema_type(s: dict[str, Any], defs: dict[str, Any], link: str = "documents.md") -> str:
    """A JSON schema written as a short type."""
    if "$ref" in s:
        name = s["$ref"].rsplit("/", 1)[-1]
        return f"[{name}]({link}#{name.lower()})" if name in documented_models() else name
    if "anyOf" in s or "oneOf" in s:
        return " or ".join(_schema_type(x, defs, link) for x in s.get("anyOf", s.get("oneOf", [])))
    if "const" in s:
        return json.dumps(s["const"])
    if "enum" in s:
        return " | ".join(json.dumps(v) for v in s["enum"])
    t = s.get("type")
    if t == "array":
        inner = _schema_type(s.get("items", {}), defs, link) if s.get("items") else "any"
        n = s.get("minItems")
        if n is not None and n == s.get("maxItems"):
            return f"[{inner} × {n}]"
        return f"list of {inner}"
    if t == "object":
        extra = s.get("additionalProperties")
        return f"{{name: {_schema_type(extra, defs, link)}}}" if isinstance(extra, dict) else "object"
    return str(t or "any")


def _limits(s: dict[str, Any]) -> str:
    keys = {"minimum": "≥", "maximum": "≤", "exclusiveMinimum": ">", "exclusiveMaximum": "<",
            "minLength": "length ≥", "maxLength": "length ≤", "minItems": "items ≥", "maxItems": "items ≤",
            "minProperties": "entries ≥", "maxProperties": "entries ≤"}
    parts = [f"{v} {s[k]:g}" if isinstance(s[k], float) else f"{v} {s[k]}" for k, v in keys.items() if k in s]
    if s.get("type") == "array" and s.get("minItems") == s.get("maxItems") and "minItems" in s:
        parts = [p for p in parts if not p.startswith("items")]
    for x in s.get("anyOf", []) + ([s["items"]] if isinstance(s.get("items"), dict) else []):
        if "$ref" not in x:
            inner = _limits(x)
            if inner:
                parts.append(inner)
    return ", ".join(dict.fromkeys(parts))


def openapi() -> dict[str, Any]:
    """The OpenAPI document of an app built on a throw-away data directory."""
    from service.app import create_app
    from service.settings import Settings

    with tempfile.TemporaryDirectory() as d:
        return create_app(Settings(data_dir=d, load_kernels=False)).openapi()


def rest_page() -> str:
    """One section per route of the OpenAPI document."""
    doc = openapi()
    defs = doc.get("components", {}).get("schemas", {})
    out = [text.REST_INTRO.format(version=doc.get("info", {}).get("version", ""))]
    for path, ops in doc["paths"].items():
        for method, op in ops.items():
            out.append(f"\n## {method.upper()} `{path}`\n\n**{op.get('summary', '')}**\n\n")
            if op.get("description"):
                out.append(op["description"].strip() + "\n\n")
            params = op.get("parameters", [])
            if params:
                out.append(table(["parameter", "in", "required", "type", "default", "description"], [
                    [code(p["name"]), p["in"], "yes" if p.get("required") else "",
                     _schema_type(p.get("schema", {}), defs, "documents.md"),
                     code(json.dumps(p["schema"]["default"])) if "default" in p.get("schema", {}) else "",
                     p.get("description") or p.get("schema", {}).get("description", "")] for p in params]))
                out.append("\n")
            body = op.get("requestBody")
            if body:
                kinds = [f"`{ct}`: {_schema_type(c.get('schema', {}), defs)}" for ct, c in body["content"].items()]
                out.append("Body " + ("(required)" if body.get("required") else "(optional)") + ": "
                           + "; ".join(kinds) + "\n\n")
                for c in body["content"].values():
                    name = c.get("schema", {}).get("$ref", "").rsplit("/", 1)[-1]
                    if name and name not in documented_models() and name in defs:
                        out.append(_fields_table(defs[name], defs, "documents.md", name) + "\n")
            rows = []
            for status, r in sorted(op.get("responses", {}).items()):
                content = r.get("content", {})
                kinds = ", ".join(f"`{ct}`" + (f" {_schema_type(c['schema'], defs)}" if c.get("schema") else "")
                                  for ct, c in content.items())
                rows.append([status, r.get("description", ""), kinds])
            out.append(table(["status", "answer", "content"], rows))
    out.append(text.REST_STREAM)
    return "".join(out)


# ---------------------------------------------------------------------------------------------- formats

def plain(words: str) -> str:
    r"""Text shown as written: ``*NODE`` and ``SET_NODE`` escaped, not read as Markdown emphasis.

    Examples
    --------
    >>> plain("*NODE/*ELEMENT, *SET_NODE")
    '\\*NODE/\\*ELEMENT, \\*SET\\_NODE'
    """
    return re.sub(r"([\\`*_\[\]])", r"\\\1", words)


def formats_page() -> str:
    """Every mesh format: what is read, written and kept, as measured by round trips or said by its reader."""
    from service.format_table import TABLE
    from service.formats import SURFACE_FORMATS, capabilities, registered

    def mark(v: Any) -> str:
        return "—" if v is None else "yes" if v else "no"

    formats = capabilities()
    rows = [[code(f["name"]), code(f["extension"]), mark(f["read"]), mark(f["write"]), mark(f["sets"]),
             mark(f["quadratic"]), mark(f["mixed"]), code(f["needs"]) if f["needs"] else "",
             mark(f["available"]), mark(f["in_place"])] for f in formats]
    own = registered()
    readers = []
    for f in formats:
        if f["name"] not in own:
            continue
        exts = ", ".join(code(e) for e in f["extensions"])
        aliases = ", ".join(code(a) for a in own[f["name"]].aliases)
        written = ("written back in place, and converted to from other formats" if f["converts_to"] else
                   "written back in place only, to decks read from it: a mesh of another format is not converted "
                   "to it (422 `unwritable_format`)")
        readers.append(f"\n### {f['title']}\n\n`format`: {code(f['name'])}"
                       + (f" (or {aliases})" if aliases else "") + f"; extensions {exts}; {written}.\n\n"
                       + f"- **Reads:** {plain(f['reads'] or '—')}\n- **Refuses:** {plain(f['refuses'] or '—')}\n")
    surfaces = ", ".join(f"{code(ext)} ({name})" for name, ext in SURFACE_FORMATS.items())
    return (text.FORMATS_INTRO.format(meshio=TABLE.get("meshio", ""))
            + table(["format", "extension", "read", "write", "keeps node sets", "keeps tetra10",
                     "keeps mixed elements", "needs", "offered here", "written back in place"], rows)
            + f"\nTriangle surfaces (targets of `SPEC.targets`, inputs of `tetrahedralize`): {surfaces}.\n"
            + text.FORMATS_READERS + "".join(readers))


# -------------------------------------------------------------------------------------------- documents

def document_roots() -> list[tuple[str, Any, dict[str, Any]]]:
    """The documents the page describes: title, model and JSON schema of each."""
    import service.models.batch as batch
    import service.models.move as frame
    import service.models.session as session
    import solver.documents.move as move
    import solver.documents.report as report
    import solver.documents.shapes as shapes
    import solver.documents.spec as spec

    roots = [("SPEC", spec.Spec, "validation"), ("MOVE", move.Move, "validation"),
             ("Stream frame", frame.StreamFrame, "validation"), ("REPORT", report.Report, "serialization"),
             ("SHAPES", shapes.Shapes, "validation"),
             ("Batch (SHAPES and PLAN)", batch.BatchCreate, "validation"),
             ("Bounds query", batch.BoundsQuery, "validation"),
             ("Session presets", session.SessionPatch, "validation")]
    return [(title, model, model.model_json_schema(mode=mode, ref_template="#/$defs/{model}"))
            for title, model, mode in roots]


@functools.cache
def documented_models() -> frozenset[str]:
    """Names of the models that have a section on the documents page."""
    names = set()
    for _, model, schema in document_roots():
        names |= {model.__name__, *schema.get("$defs", {})}
    return frozenset(names)


def documents_page() -> str:
    """SPEC, MOVE, REPORT and SHAPES field by field, from their pydantic models."""
    out = [text.DOCUMENTS_INTRO]
    seen: set[str] = set()
    notes = set(text.FIELD_NOTES)
    for title, model, schema in document_roots():
        schema = dict(schema)
        defs = schema.pop("$defs", {})
        out.append(_model_section(model.__name__, schema, defs, level=2, title=title, notes=notes))
        for name in sorted(defs):
            if name not in seen and name != model.__name__:
                out.append(_model_section(name, defs[name], defs, level=3, notes=notes))
            seen.add(name)
        seen.add(model.__name__)
    stale("field note", notes)
    return "".join(out)


@functools.cache
def model_classes() -> dict[str, Any]:
    """The pydantic models of ``solver.documents`` and ``service.models`` by class name.

    Used for the defaults that factories make.
    """
    import importlib
    import pkgutil

    from pydantic import BaseModel

    import service.models as models
    import solver.documents as documents

    found: dict[str, Any] = {}
    for package in (documents, models):
        for m in pkgutil.iter_modules(package.__path__):
            mod = importlib.import_module(f"{package.__name__}.{m.name}")
            for obj in vars(mod).values():
                if isinstance(obj, type) and issubclass(obj, BaseModel) and obj.__module__ == mod.__name__:
                    found.setdefault(obj.__name__, obj)
    return found


def _default(model: str, field: str, f: dict[str, Any], required: set[str]) -> str:
    if field in required:
        return "required"
    if "default" in f:
        return code(json.dumps(f["default"]))
    cls = model_classes().get(model)
    info = cls.model_fields.get(field) if cls is not None else None
    if info is not None and info.default_factory is not None:
        try:
            return code(json.dumps(info.default_factory()))
        except (TypeError, ValueError):
            return ""
    return ""


def _fields_table(s: dict[str, Any], defs: dict[str, Any], link: str, model: str = "",
                  notes: set[str] | None = None) -> str:
    """The fields of an object schema: type, default, bounds, description."""
    required = set(s.get("required", []))
    rows = []
    for field, f in s.get("properties", {}).items():
        default = _default(model or s.get("title", ""), field, f, required)
        desc = f.get("description") or next((x.get("description") for x in f.get("anyOf", [])
                                             if x.get("description")), "") or ""
        items = f.get("items") if isinstance(f.get("items"), dict) else {}
        if not desc and items.get("description"):
            desc = items["description"]
        note = text.FIELD_NOTES.get(f"{model}.{field}")
        if note:
            desc = _merge(note, desc)
            if notes is not None:
                notes.discard(f"{model}.{field}")
        rows.append([code(field), _schema_type(f, defs, link), default, _limits(f), desc])
    return table(["field", "type", "default", "bounds", "description"], rows) if rows else ""


def _merge(note: str, desc: str) -> str:
    """A field's hand-written note and its model's description, joined.

    Once only when one starts with the other (punctuation aside).
    """
    a, b = (" ".join(s.split()) for s in (note, desc))
    words_a, words_b = (" ".join(re.findall(r"\w+", s)) for s in (a, b))
    if not b or words_b.startswith(words_a):
        return b or a
    return a if words_a.startswith(words_b) else f"{a}; {b}"


def _model_section(name: str, s: dict[str, Any], defs: dict[str, Any], level: int, title: str = "",
                   notes: set[str] | None = None) -> str:
    head = "#" * level
    doc = re.sub(r"\s*\((?:README|docs/)[^)]*\)", "", (s.get("description") or "").strip())
    extra = "" if s.get("additionalProperties", True) is not False else "Unknown fields are refused.\n\n"
    heading = f"{title} (`{name}`)" if title else name
    return (f"\n{head} {heading} {{#{name.lower()}}}\n\n" + (doc + "\n\n" if doc else "") + extra
            + _fields_table(s, defs, "", name, notes))
