"""``python -m service.cluster up|down``: the local cluster of ``make cluster`` and ``make cluster-down``.

::

    python -m service.cluster up --dir /tmp/tetmorph-cluster --replicas 3 --port 8100
    python -m service.cluster down --dir /tmp/tetmorph-cluster
"""

from __future__ import annotations

import argparse
import sys

from .local import LocalCluster, stop_saved


def main(argv: list[str] | None = None) -> int:
    """Start or stop the local cluster."""
    p = argparse.ArgumentParser(prog="python -m service.cluster", description=__doc__.splitlines()[0])
    p.add_argument("action", choices=["up", "down"])
    p.add_argument("--dir", default="/tmp/tetmorph-cluster", help="state, logs, database and data directory")
    p.add_argument("--replicas", type=int, default=3)
    p.add_argument("--port", type=int, default=8100, help="the balancer's port")
    p.add_argument("--first-replica-port", type=int, default=8101)
    p.add_argument("--pg-port", type=int, default=8199)
    args = p.parse_args(argv)
    if args.action == "down":
        print("stopped" if stop_saved(args.dir) else f"no cluster in {args.dir}")
        return 0
    if stop_saved(args.dir):
        print("stopped the cluster that was running")
    c = LocalCluster(args.dir, args.replicas, args.port,
                     [args.first_replica_port + k for k in range(args.replicas)], args.pg_port)
    try:
        c.start()
    except BaseException:
        c.stop()
        raise
    print(f"tetmorph cluster: balancer {c.url} -> " + ", ".join(f"{n} {c.replica_url(n)}" for n in c.names())
          + f"; PostgreSQL {c.pg.url}; data {c.data}; logs in {c.folder}. Stop: make cluster-down")
    return 0


if __name__ == "__main__":
    sys.exit(main())
