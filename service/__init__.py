"""tetmorph REST service (FastAPI). Depends on :mod:`solver`; never the reverse.

The HTTP resources (meshes, sessions, deform, WebSocket streaming) are built on
the same SPEC / MOVE / REPORT documents as the library and the CLI.
"""
