"""The ``tetmorph`` command: the solver's commands plus ``serve``.

``tetmorph info`` and ``tetmorph morph`` need only the base install (the
numerics). ``tetmorph serve [--host] [--port] [--data-dir] [--demo]`` runs the
REST service with uvicorn (one worker process; sessions live in its memory)
and needs the ``service`` extra; without it, it says so and exits with
:data:`EXIT_NO_SERVICE`. Nothing of the web stack is imported before ``serve``
runs.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from typing import Any

from solver.cli import main as solver_main

__all__ = ["main", "EXIT_NO_SERVICE", "missing_service_packages"]

#: Exit code of ``tetmorph serve`` when the ``service`` extra is not installed.
EXIT_NO_SERVICE = 3
#: Modules of the ``service`` extra that ``serve`` imports.
SERVICE_MODULES = ("fastapi", "uvicorn", "pydantic_settings", "multipart", "httpx",
                   "prometheus_client")


def missing_service_packages() -> list[str]:
    """The modules of the ``service`` extra that cannot be imported here."""
    out = []
    for m in SERVICE_MODULES:
        try:
            if importlib.util.find_spec(m) is None:
                out.append(m)
        except (ImportError, ValueError):
            out.append(m)
    return out


def cmd_serve(args: argparse.Namespace) -> int:
    """Run the service until interrupted."""
    missing = missing_service_packages()
    if missing:
        print(f"tetmorph: error [missing_extra]: 'tetmorph serve' needs the service extra (missing: "
              f"{', '.join(missing)}); install it with: pip install 'tetmorph[service]'", file=sys.stderr)
        return EXIT_NO_SERVICE
    import uvicorn

    from .app import create_app
    from .http_protocol import bounded_protocol
    from .observability import configure_logging
    from .settings import Settings

    overrides: dict[str, Any] = {"demo": True} if args.demo else {}  # TETMORPH_DEMO=1 still applies
    if args.data_dir:
        overrides["data_dir"] = args.data_dir
    settings = Settings(**overrides)
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    configure_logging(args.log_level, settings.log_json)
    app = create_app(settings)
    url = f"http://{args.host}:{args.port}"
    print(f"tetmorph service on {url}  (browser editor: {url}/ ; OpenAPI docs: {url}/docs)", flush=True)
    print(f"data directory: {settings.data_dir}", flush=True)
    if args.demo:
        print(f"demo session: {url}/v1/sessions/s_demo  (mesh m_demo_beam). Try:\n"
              f"  curl -X POST '{url}/v1/sessions/s_demo/deform?result=report' "
              "-H 'content-type: application/json' "
              "-d '{\"handles\": {\"tip\": {\"translation\": [0, 0, 0.2]}}}'", flush=True)
    uvicorn.run(app, host=args.host, port=args.port, workers=1, log_level=args.log_level, log_config=None,
                access_log=False, ws_max_size=settings.max_frame_bytes + 1024,
                http=bounded_protocol(settings.head_timeout_s, settings.http_impl, settings.max_header_bytes,
                                      settings.max_headers))
    return 0


def _doe(args: argparse.Namespace, local: Any) -> int:
    """``tetmorph doe``: this process, or Ray actors with ``--engine ray``."""
    if args.engine == "ray":
        from solver.workflows.ray_engine import cmd_doe_ray

        return cmd_doe_ray(args)
    return int(local(args))


def _study(args: argparse.Namespace, local: Any) -> int:
    """``tetmorph study``: this process, or the morphs on Ray actors and each solver run a task."""
    if args.engine == "ray":
        from solver.workflows.ray_study import cmd_study_ray

        return cmd_study_ray(args)
    return int(local(args))


def add_engine(sub: Any) -> None:
    """Give ``tetmorph doe`` and ``tetmorph study`` their ``--engine ray [--address ADDR] [--actors N]``."""
    from solver.workflows.ray_engine import add_ray_options

    for name, run in (("doe", _doe), ("study", _study)):
        cmd = sub.choices.get(name)
        if cmd is None:
            continue
        add_ray_options(cmd)
        local = cmd.get_default("func")
        cmd.set_defaults(func=lambda args, run=run, local=local: run(args, local))


def add_serve(sub: Any) -> None:
    """Add the ``serve`` subcommand to the solver's parser (and the Ray engine of ``doe``)."""
    add_engine(sub)
    ps = sub.add_parser("serve", help="run the REST service (uvicorn, one worker; needs the service extra)")
    ps.add_argument("--host", default="127.0.0.1")
    ps.add_argument("--port", type=int, default=8000)
    ps.add_argument("--data-dir", help="where meshes and sessions persist (TETMORPH_DATA_DIR)")
    ps.add_argument("--demo", action="store_true", help="load the demo beam and session s_demo")
    ps.add_argument("--log-level", default="info",
                    choices=["critical", "error", "warning", "info", "debug"])
    ps.set_defaults(func=cmd_serve)


def main(argv: list[str] | None = None) -> int:
    """Run the ``tetmorph`` command line (``info``, ``morph``, ``serve``)."""
    return solver_main(argv, extend=add_serve)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
