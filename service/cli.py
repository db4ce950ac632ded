"""The ``tetmorph`` command: the solver's commands plus ``serve``.

``tetmorph serve [--host] [--port] [--data-dir] [--demo]`` runs the REST
service with uvicorn (one worker process; sessions live in its memory).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from solver.cli import main as solver_main

__all__ = ["main"]


def cmd_serve(args: argparse.Namespace) -> int:
    """Run the service until interrupted."""
    import uvicorn

    from .app import create_app
    from .settings import Settings

    overrides: dict[str, Any] = {"demo": args.demo}
    if args.data_dir:
        overrides["data_dir"] = args.data_dir
    settings = Settings(**overrides)
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    app = create_app(settings)
    url = f"http://{args.host}:{args.port}"
    print(f"tetmorph service on {url}  (browser editor: {url}/ ; OpenAPI docs: {url}/docs)", flush=True)
    print(f"data directory: {settings.data_dir}", flush=True)
    if args.demo:
        print(f"demo session: {url}/v1/sessions/s_demo  (mesh m_demo_beam). Try:\n"
              f"  curl -X POST '{url}/v1/sessions/s_demo/deform?result=report' "
              "-H 'content-type: application/json' "
              "-d '{\"handles\": {\"tip\": {\"translation\": [0, 0, 0.2]}}}'", flush=True)
    uvicorn.run(app, host=args.host, port=args.port, workers=1, log_level=args.log_level,
                ws_max_size=64 * 1024 * 1024)
    return 0


def add_serve(sub: Any) -> None:
    """Add the ``serve`` subcommand to the solver's parser."""
    ps = sub.add_parser("serve", help="run the REST service (uvicorn, one worker)")
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
