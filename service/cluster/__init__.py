"""Running several replicas on one machine: a local PostgreSQL, HAProxy and ``tetmorph serve`` processes.

* :mod:`~service.cluster.postgres` -- Debian's PostgreSQL in a local folder (initdb as an unprivileged user);
* :mod:`~service.cluster.haproxy` -- the balancer's configuration (consistent hashing on the session id);
* :mod:`~service.cluster.local` -- the cluster of ``make cluster`` and the cluster tests;
* :mod:`~service.cluster.__main__` -- ``python -m service.cluster up|down``.

Every server listens on 127.0.0.1 only.
"""
