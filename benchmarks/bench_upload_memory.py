"""Peak memory of the server and of its parse workers during hostile uploads, and the other tenant's latency.

Starts ``tetmorph serve`` on 127.0.0.1 (two API keys, ``bomber`` and
``peer``; ``TETMORPH_MAX_FILE_EXPANDED_MB`` set to ``--expanded-mb``, the
other settings their defaults) and samples every 50 ms, with psutil, the RSS
of the server process and of each of its child processes (the parse
workers). Each upload keeps the peak of the server, of the largest child and
of their sum at one sample; the server's and the children's ``VmHWM`` are
reset when the upload starts and read when it is answered, so that a peak
between two samples still counts.

The uploads, built in a temporary folder and sent as ``bomber``
(``POST /v1/meshes``, multipart), the large ones at each count of ``--points``:

``vtu-points N``
    a zlib VTU whose appended (base64) points array declares and holds N
    points, zeros but the four corners of its one tetrahedron: a few hundred
    KB, ``24 N`` bytes once expanded; under the bound, every check made
    before reading lets it through.
``vtu-lying-small``
    a zlib VTU of four points whose block header declares 96 bytes while
    its one block expands to ``--lie-mb`` MiB: only the bound applied while
    decompressing can stop it.
``vtu-lying-large N``
    a zlib VTU whose header declares N points and a block of ``24 N``
    bytes, while the block holds the four corners only.
``xdmf-h5 N``
    an XDMF file with its ``.h5`` as a companion: a gzip, chunked dataset of
    N x 3 doubles of which only the first chunk is stored.
``hmf N``
    meshio's HDF5 mesh file, the same dataset as its Geometry.
``honest``
    a valid mesh for comparison (``../shared/data/tet/cube_big_tetra.mesh``,
    else ``tests/data/bracket.inp``).

Each upload runs on a server of its own, started for it, ``--repeats`` times
in turn (median [min-max] over the repeats), so that what one upload leaves
in the server's or a worker's memory shows in its own repeats only
(``--one-server``: every upload on one server, the bombs in turn and the
honest mesh after them); a mesh that is stored is deleted again. While
an upload is in flight a second thread uploads ``tests/data/plate.inp`` as
``peer`` (then deletes it) and times ``GET /health``, every
``--peer-interval`` s; the same rounds on the quiet server just before each
upload are the peer measured in the same run. ``--load N`` runs N busy-loop
processes (the ``spin`` load of ``bench_contention.py``) on the cores while
measuring: started once a server is ready, killed when its uploads are done
(each also stops by itself after ``--busy-limit`` s).

``server / bound`` divides the server's peak RSS by the expanded-size bound
(target: at most 1.5); ``growth / bound`` divides what the server added
during the upload (its peak less its RSS just before) by the same bound.

    python benchmarks/bench_upload_memory.py [--repeats 3] [--load 0] [--expanded-mb 256]
                                             [--points 10000000,5000000] [--one-server]
"""

from __future__ import annotations

import argparse
import base64
import os
import platform
import shutil
import signal
import statistics
import struct
import subprocess
import sys
import tempfile
import threading
import time
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import httpx
import numpy as np
import psutil

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_contention import BUSY, cores  # noqa: E402

MIB = 2**20
#: The four corners of the one tetrahedron every bomb holds (positive volume).
TET = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
#: Uncompressed bytes per VTU block (VTK writes 32 KiB; larger blocks keep the header short).
BLOCK = MIB
KEYS = ("bomber", "peer")


# ------------------------------------------------------------------ the uploads


def _b64(b: bytes) -> bytes:
    return base64.b64encode(b)


def _array(blocks: list[bytes], block: int, last: int) -> bytes:
    """A zlib-compressed VTK binary array: base64 of the UInt64 header, then base64 of the blocks."""
    header = struct.pack(f"<{3 + len(blocks)}Q", len(blocks), block, last, *(len(c) for c in blocks))
    return _b64(header) + _b64(b"".join(blocks))


def _zero_blocks(head: bytes, total: int) -> tuple[list[bytes], int, int]:
    """Compressed blocks of ``total`` bytes that begin with ``head``, zeros after (each distinct block once)."""
    nblocks = -(-total // BLOCK)
    last = total - (nblocks - 1) * BLOCK
    zero = zlib.compress(bytes(BLOCK), 9)
    blocks = [zlib.compress(head + bytes(min(BLOCK, total) - len(head)), 9)]
    blocks += [zero] * max(0, nblocks - 2)
    if nblocks > 1:
        blocks.append(zlib.compress(bytes(last), 9))
    return blocks, BLOCK if nblocks > 1 else total, last


def _vtu(path: Path, points_declared: int, points_array: bytes) -> None:
    """A VTU of one tetrahedron, its arrays appended (base64), the points array given already encoded."""
    conn = _array([zlib.compress(np.arange(4, dtype=np.int64).tobytes(), 9)], 32, 32)
    offs = _array([zlib.compress(np.array([4], dtype=np.int64).tobytes(), 9)], 8, 8)
    types = _array([zlib.compress(np.array([10], dtype=np.uint8).tobytes(), 9)], 1, 1)
    arrays, offsets, at = [points_array, conn, offs, types], [], 0
    for a in arrays:
        offsets.append(at)
        at += len(a)
    path.write_bytes(
        b'<?xml version="1.0"?>\n'
        b'<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64" '
        b'compressor="vtkZLibDataCompressor">\n<UnstructuredGrid>\n'
        + f'<Piece NumberOfPoints="{points_declared}" NumberOfCells="1">\n'.encode()
        + f'<Points>\n<DataArray type="Float64" NumberOfComponents="3" format="appended" '
          f'offset="{offsets[0]}"/>\n</Points>\n<Cells>\n'
          f'<DataArray type="Int64" Name="connectivity" format="appended" offset="{offsets[1]}"/>\n'
          f'<DataArray type="Int64" Name="offsets" format="appended" offset="{offsets[2]}"/>\n'
          f'<DataArray type="UInt8" Name="types" format="appended" offset="{offsets[3]}"/>\n'
          '</Cells>\n</Piece>\n</UnstructuredGrid>\n<AppendedData encoding="base64">\n_'.encode()
        + b"".join(arrays) + b"\n</AppendedData>\n</VTKFile>\n")


def vtu_points(path: Path, points: int) -> None:
    """``points`` points declared and stored (zeros but the tetrahedron's corners), compressed."""
    blocks, block, last = _zero_blocks(TET.tobytes(), 24 * points)
    _vtu(path, points, _array(blocks, block, last))


def vtu_lying_small(path: Path, expand_bytes: int) -> None:
    """Four points whose one block header says 96 bytes while the block expands to ``expand_bytes``."""
    z = zlib.compressobj(9)
    parts = [z.compress(TET.tobytes())]
    zero = bytes(BLOCK)
    for _ in range(expand_bytes // BLOCK):
        parts.append(z.compress(zero))
    parts.append(z.flush())
    _vtu(path, 4, _array([b"".join(parts)], 96, 96))


def vtu_lying_large(path: Path, points: int) -> None:
    """``points`` points and a block of ``24 * points`` bytes declared; the block holds the four corners."""
    _vtu(path, points, _array([zlib.compress(TET.tobytes(), 9)], 24 * points, 24 * points))


def _big_points(group, name: str, points: int) -> None:
    """A gzip, chunked ``points`` x 3 dataset of which only the first chunk (the corners, zeros) is written."""
    ds = group.create_dataset(name, shape=(points, 3), dtype="f8", chunks=(min(points, 65536), 3),
                              compression="gzip", compression_opts=9, fillvalue=0.0)
    ds[:4] = TET


def xdmf_h5(path: Path, points: int) -> Path:
    """An XDMF file and its ``.h5``; the latter is returned (the companion)."""
    import h5py

    h5 = path.with_suffix(".h5")
    with h5py.File(h5, "w") as f:
        _big_points(f, "geometry", points)
        f.create_dataset("topology", data=np.arange(4, dtype=np.int64).reshape(1, 4))
    path.write_text(
        '<?xml version="1.0"?>\n<Xdmf Version="3.0">\n<Domain>\n<Grid Name="Grid">\n'
        f'<Geometry GeometryType="XYZ"><DataItem DataType="Float" Dimensions="{points} 3" Format="HDF" '
        f'Precision="8">{h5.name}:/geometry</DataItem></Geometry>\n'
        '<Topology TopologyType="Tetrahedron" NumberOfElements="1"><DataItem DataType="Int" Dimensions="1 4" '
        f'Format="HDF" Precision="8">{h5.name}:/topology</DataItem></Topology>\n'
        '</Grid>\n</Domain>\n</Xdmf>\n')
    return h5


def hmf(path: Path, points: int) -> None:
    """meshio's HMF layout (``/domain/grid``) of one tetrahedron, its Geometry the large dataset."""
    import h5py

    with h5py.File(path, "w") as f:
        f.attrs["type"] = "hmf"
        f.attrs["version"] = "0.1-alpha"
        grid = f.create_group("domain").create_group("grid")
        _big_points(grid, "Geometry", points)
        grid["Geometry"].attrs["GeometryType"] = "XYZ"
        topo = grid.create_dataset("Topology0", data=np.arange(4, dtype=np.int64).reshape(1, 4))
        topo.attrs["TopologyType"] = "Tetrahedron"
        grid.create_group("NodeAttributes")
        grid.create_group("CellAttributes")


@dataclass
class Upload:
    name: str
    path: Path
    companions: list[Path] = field(default_factory=list)
    expands_mb: float = 0.0  # what its data arrays take once read


def _count(n: int) -> str:
    return f"{n / 1e6:g}M" if n >= 1_000_000 else f"{n:,}"


def build_uploads(work: Path, points: list[int], lie_mb: int) -> list[Upload]:
    """The bombs (each large one at every count of ``points``), then the honest mesh."""
    out = []
    for n in points:
        p = work / f"points_{n}.vtu"
        vtu_points(p, n)
        out.append(Upload(f"vtu-points {_count(n)}", p, expands_mb=24 * n / MIB))
    p = work / "lying_small.vtu"
    vtu_lying_small(p, lie_mb * MIB)
    out.append(Upload("vtu-lying-small", p, expands_mb=lie_mb))
    p = work / "lying_large.vtu"
    vtu_lying_large(p, max(points))
    out.append(Upload(f"vtu-lying-large {_count(max(points))}", p, expands_mb=96 / MIB))
    for n in points:
        p = work / f"bomb_{n}.xdmf"
        out.append(Upload(f"xdmf-h5 {_count(n)}", p, [xdmf_h5(p, n)], expands_mb=24 * n / MIB))
    for n in points:
        p = work / f"bomb_{n}.hmf"
        hmf(p, n)
        out.append(Upload(f"hmf {_count(n)}", p, expands_mb=24 * n / MIB))
    honest = ROOT.parent / "shared" / "data" / "tet" / "cube_big_tetra.mesh"
    if not honest.exists():
        honest = ROOT / "tests" / "data" / "bracket.inp"
    out.append(Upload("honest", honest))
    return out


# ------------------------------------------------------------------ memory sampling


@dataclass
class Window:
    """Peaks over one upload (bytes): the server, the largest child, and the two summed at one sample."""

    server_before: int = 0
    child_before: int = 0
    server: int = 0
    child: int = 0
    total: int = 0
    samples: int = 0


def _hwm(pid: int) -> int:
    """The process's peak RSS since its last reset (``VmHWM``), 0 where it cannot be read."""
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def _reset_hwm(pid: int) -> None:
    """Reset the process's ``VmHWM`` to its current RSS (``clear_refs`` 5: nothing else is touched)."""
    try:
        with open(f"/proc/{pid}/clear_refs", "w", encoding="ascii") as fh:
            fh.write("5")
    except OSError:
        pass


class Sampler:
    """RSS of a process and of each of its children every ``interval`` s, into the open windows.

    A window also resets the processes' ``VmHWM`` when it opens and reads it when it closes, so that a
    peak shorter than the interval is not missed (for the server and for children alive at both ends).
    """

    def __init__(self, pid: int, interval: float = 0.05) -> None:
        self.proc = psutil.Process(pid)
        self.interval = interval
        self.windows: list[Window] = []
        self.lock = threading.Lock()
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, name="rss-sampler", daemon=True)
        self.thread.start()

    def sample(self) -> tuple[int, dict[int, int]]:
        server = self.proc.memory_info().rss
        kids: dict[int, int] = {}
        for c in self.proc.children(recursive=True):
            try:
                kids[c.pid] = c.memory_info().rss
            except psutil.Error:  # a worker replaced between the listing and the reading
                pass
        return server, kids

    @staticmethod
    def _add(w: Window, server: int, kids: dict[int, int]) -> None:
        w.server = max(w.server, server)
        w.child = max(w.child, max(kids.values(), default=0))
        w.total = max(w.total, server + sum(kids.values()))

    def _run(self) -> None:
        while not self.stop.wait(self.interval):
            try:
                server, kids = self.sample()
            except psutil.Error:
                return  # the server is gone
            with self.lock:
                for w in self.windows:
                    self._add(w, server, kids)
                    w.samples += 1

    def open(self) -> Window:
        server, kids = self.sample()
        for pid in [self.proc.pid, *kids]:
            _reset_hwm(pid)
        w = Window(server_before=server, child_before=max(kids.values(), default=0))
        self._add(w, server, kids)
        with self.lock:
            self.windows.append(w)
        return w

    def close(self, w: Window) -> Window:
        server, kids = self.sample()
        with self.lock:
            self.windows.remove(w)
            self._add(w, server, kids)
            w.server = max(w.server, _hwm(self.proc.pid))
            w.child = max([w.child, *(_hwm(pid) for pid in kids)])
        return w

    def children(self) -> int:
        try:
            return len(self.proc.children(recursive=True))
        except psutil.Error:
            return 0

    def shutdown(self) -> None:
        self.stop.set()
        self.thread.join(2)


# ------------------------------------------------------------------ the server


def start_server(data: Path, env: dict[str, str], startup_s: float = 120.0) -> tuple[str, subprocess.Popen]:
    """``tetmorph serve`` on a free port of 127.0.0.1, once ``/ready`` answers 200."""
    from service.process import free_port

    port = free_port()
    exe = Path(sys.executable).with_name("tetmorph")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "service.cli"]
    log = open(data.parent / "server.log", "w")  # noqa: SIM115 - closed with the process's pipes
    proc = subprocess.Popen([*cmd, "serve", "--host", "127.0.0.1", "--port", str(port), "--data-dir", str(data),
                             "--log-level", "warning"], env=dict(os.environ, **env), stdout=log,
                            stderr=subprocess.STDOUT, cwd=data.parent)
    log.close()
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + startup_s
    while True:
        try:
            if httpx.get(url + "/ready", timeout=2).status_code == 200:
                return url, proc
        except httpx.TransportError:
            pass
        if proc.poll() is not None or time.monotonic() > deadline:
            stop_server(proc)
            raise RuntimeError(f"tetmorph serve did not start: {(data.parent / 'server.log').read_text()[-2000:]}")
        time.sleep(0.2)


def stop_server(proc: subprocess.Popen) -> None:
    """SIGTERM, then SIGKILL; then any child still alive (the parse workers end with their pipes)."""
    try:
        kids = psutil.Process(proc.pid).children(recursive=True)
    except psutil.Error:
        kids = []
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    for k in kids:
        try:
            k.wait(5)
        except psutil.TimeoutExpired:
            k.kill()
        except psutil.Error:
            pass


def wait_workers(url: str, sampler: Sampler, workers: int, limit_s: float = 60.0) -> None:
    """Until ``/ready`` answers 200 and the server has at least ``workers`` children (a killed one replaced)."""
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        try:
            ok = httpx.get(url + "/ready", timeout=5).status_code == 200
        except httpx.TransportError:
            ok = False
        if ok and sampler.children() >= workers:
            return
        time.sleep(0.2)
    print(f"  (workers not back after {limit_s:.0f} s: {sampler.children()} children)", flush=True)


def upload(c: httpx.Client, u: Upload, timeout: float) -> tuple[int, str, float, str | None]:
    """``POST /v1/meshes``: status, code (``created`` for 201), seconds, the new mesh's id."""
    files = [("file", (u.path.name, u.path.read_bytes()))]
    files += [("companions", (p.name, p.read_bytes())) for p in u.companions]
    t0 = time.perf_counter()
    try:
        r = c.post("/v1/meshes", files=files, timeout=timeout)
    except httpx.TimeoutException:
        return 0, "client_timeout", time.perf_counter() - t0, None
    except httpx.TransportError as e:
        return 0, type(e).__name__, time.perf_counter() - t0, None
    s = time.perf_counter() - t0
    body = r.json() if r.headers.get("content-type", "").startswith("application/json") else {}
    if r.status_code == 201:
        return 201, "created", s, body.get("id")
    return r.status_code, (body.get("error") or {}).get("code", "?"), s, None


# ------------------------------------------------------------------ the other tenant


class Peer:
    """Uploads a small mesh as ``peer`` (then deletes it) and times ``GET /health``, paced, in a thread."""

    def __init__(self, url: str, mesh: Path, interval: float) -> None:
        self.c = httpx.Client(base_url=url, headers={"X-API-Key": "peer"}, timeout=60)
        self.up = Upload("peer", mesh)
        self.interval = interval
        self.errors: list[str] = []

    def round(self, uploads: list[float], health: list[float]) -> None:
        t0 = time.perf_counter()
        try:
            r = self.c.get("/health")
            if r.status_code == 200:
                health.append(1e3 * (time.perf_counter() - t0))
            else:
                self.errors.append(f"health {r.status_code}")
        except httpx.HTTPError as e:
            self.errors.append(f"health {type(e).__name__}")
        status, code, s, mid = upload(self.c, self.up, 60)
        if status == 201:
            uploads.append(1e3 * s)
            self.c.delete(f"/v1/meshes/{mid}")
        else:
            self.errors.append(f"upload {status} {code}")

    def quiet(self, rounds: int) -> tuple[list[float], list[float]]:
        uploads: list[float] = []
        health: list[float] = []
        for _ in range(rounds):
            self.round(uploads, health)
            time.sleep(self.interval)
        return uploads, health

    def during(self, done: threading.Event, most: int = 400, limit_s: float = 180.0
               ) -> tuple[threading.Thread, list[float], list[float]]:
        """Rounds until ``done`` (at least one, at most ``most`` or ``limit_s``), in a thread."""
        uploads: list[float] = []
        health: list[float] = []

        def run() -> None:
            end = time.monotonic() + limit_s
            for _ in range(most):
                self.round(uploads, health)
                if done.wait(self.interval) or time.monotonic() > end:
                    return

        t = threading.Thread(target=run, name="peer", daemon=True)
        t.start()
        return t, uploads, health

    def close(self) -> None:
        self.c.close()


# ------------------------------------------------------------------ the run


@dataclass
class Row:
    status: int
    code: str
    seconds: float
    window: Window
    peer_up: list[float]
    peer_health: list[float]
    quiet_up: list[float]
    quiet_health: list[float]


def spread(v: list[float], fmt: str = ".0f") -> str:
    if not v:
        return "-"
    med = statistics.median(v)
    if len(v) == 1 or min(v) == max(v):
        return format(med, fmt)
    return f"{med:{fmt}} [{min(v):{fmt}}–{max(v):{fmt}}]"


def med(v: list[float]) -> str:
    return f"{statistics.median(v):.0f}" if v else "-"


def run_one(u: Upload, bomber: httpx.Client, peer: Peer, sampler: Sampler, a: argparse.Namespace) -> Row:
    """Quiet peer rounds, then the upload with the peer's rounds beside it; the mesh deleted if stored."""
    qu, qh = peer.quiet(a.peer_rounds)
    w = sampler.open()
    done = threading.Event()
    th, pu, ph = peer.during(done)
    status, code, secs, mid = upload(bomber, u, a.timeout)
    done.set()
    sampler.close(w)
    th.join(60)
    if mid:
        bomber.delete(f"/v1/meshes/{mid}")
    return Row(status, code, secs, w, pu, ph, qu, qh)


def serve_and_measure(order: list[tuple[int, Upload]], env: dict[str, str], workers: int, data: Path,
                      a: argparse.Namespace, rows: dict[str, list[Row]]) -> None:
    """Start a server, run ``order`` (repeat, upload) against it with the peer beside, stop it.

    The ``--load`` busy processes start once the server is ready and stop with the measurement.
    """
    proc = sampler = peer = None
    busy: list[subprocess.Popen] = []
    try:
        url, proc = start_server(data, env)
        sampler = Sampler(proc.pid)
        wait_workers(url, sampler, workers)
        srv, kids = sampler.sample()
        print(f"server ready: pid {proc.pid}, RSS {srv / MIB:.0f} MiB; {len(kids)} children "
              f"({', '.join(f'{v / MIB:.0f}' for v in kids.values())} MiB)", flush=True)
        peer = Peer(url, ROOT / "tests" / "data" / "plate.inp", a.peer_interval)
        peer.quiet(2)  # warm: the first reads import the format's modules in the workers
        busy = [subprocess.Popen([sys.executable, "-c", BUSY["spin"], str(a.busy_limit)]) for _ in range(a.load)]
        if busy:
            time.sleep(0.3)  # let them reach the loop
        with httpx.Client(base_url=url, headers={"X-API-Key": "bomber"}) as bomber:
            for rep, u in order:
                r = run_one(u, bomber, peer, sampler, a)
                rows[u.name].append(r)
                w = r.window
                print(f"  [{rep + 1}/{a.repeats}] {u.name}: {r.status} {r.code} in {r.seconds:.2f} s; server "
                      f"{w.server_before / MIB:.0f} -> {w.server / MIB:.0f} MiB, largest worker "
                      f"{w.child_before / MIB:.0f} -> {w.child / MIB:.0f} MiB, total {w.total / MIB:.0f} MiB "
                      f"({w.samples} samples); peer upload {med(r.peer_up)} ms (quiet {med(r.quiet_up)}), "
                      f"health {med(r.peer_health)} ms (quiet {med(r.quiet_health)})", flush=True)
                wait_workers(url, sampler, workers)
        srv, kids = sampler.sample()
        print(f"  at the end: server RSS {srv / MIB:.0f} MiB, children "
              f"{', '.join(f'{v / MIB:.0f}' for v in kids.values())} MiB", flush=True)
        if peer.errors:
            print(f"  peer errors ({len(peer.errors)}): {peer.errors[:5]}")
    finally:
        for b in busy:
            b.kill()
            b.wait()
        if peer is not None:
            peer.close()
        if sampler is not None:
            sampler.shutdown()
        if proc is not None:
            stop_server(proc)
        shutil.rmtree(data, ignore_errors=True)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--load", type=int, default=0, help="busy-loop processes on the cores while measuring")
    p.add_argument("--busy-limit", type=float, default=600.0, help="seconds after which a busy process stops itself")
    p.add_argument("--expanded-mb", type=float, default=256.0, help="TETMORPH_MAX_FILE_EXPANDED_MB of the server")
    p.add_argument("--points", default="10000000,5000000",
                   help="points the large bombs declare, comma separated (24 bytes each once read)")
    p.add_argument("--lie-mb", type=int, default=1024, help="MiB the lying VTU block expands to")
    p.add_argument("--peer-rounds", type=int, default=5, help="peer rounds on the quiet server before each upload")
    p.add_argument("--peer-interval", type=float, default=0.1, help="seconds between peer rounds")
    p.add_argument("--timeout", type=float, default=150.0, help="client timeout of one upload, seconds")
    p.add_argument("--only", help="comma-separated upload names (default: all)")
    p.add_argument("--one-server", action="store_true",
                   help="every upload on one server (default: a fresh server for each upload, its repeats in turn)")
    a = p.parse_args()
    points = [int(x) for x in a.points.split(",")]
    # a terminated run still stops its servers and busy processes (the finally clauses)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(128 + signal.SIGTERM))

    env = {"TETMORPH_MAX_FILE_EXPANDED_MB": f"{a.expanded_mb:g}", "TETMORPH_API_KEYS": ",".join(KEYS)}
    from service.settings import Settings

    saved = {k: os.environ.get(k) for k in env}
    os.environ.update(env)
    try:
        s = Settings()
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    limit = s.max_file_expanded_mb * MIB
    print(f"{platform.node()}: {cores()} cores, {psutil.virtual_memory().total / 2**30:.1f} GiB; python "
          f"{platform.python_version()}; load: {a.load} busy processes")
    print(f"server: tetmorph serve on 127.0.0.1, {' '.join(f'{k}={v}' for k, v in env.items())}")
    print(f"settings: max_upload_mb={s.max_upload_mb:g} max_file_expanded_mb={s.max_file_expanded_mb:g} "
          f"max_file_points={s.max_file_points:,} parse_workers={s.parse_workers} "
          f"parse_memory={s.parse_memory_bytes / MIB:.0f} MiB parse_time_limit_s={s.parse_time_limit_s:g} "
          f"parse_cpu_limit_s={s.parse_cpu_limit_s:g} parse_queue_depth={s.parse_queue_depth}")
    for n in points:
        if 24 * n > limit:
            print(f"note: {n:,} points expand to {24 * n / MIB:.0f} MiB, over the bound: refused before reading")

    work = Path(tempfile.mkdtemp(prefix="tetmorph-bench-bombs-"))
    try:
        t0 = time.perf_counter()
        ups = build_uploads(work, points, a.lie_mb)
        if a.only:
            ups = [u for u in ups if u.name in a.only.split(",")]
        print(f"built in {time.perf_counter() - t0:.1f} s:")
        for u in ups:
            size = sum(f.stat().st_size for f in [u.path, *u.companions])
            print(f"  {u.name}: {', '.join(f.name for f in [u.path, *u.companions])}, {size / MIB:.2f} MiB"
                  + (f", {u.expands_mb:.0f} MiB of arrays once read" if u.expands_mb >= 1 else ""))
        rows: dict[str, list[Row]] = {u.name: [] for u in ups}
        t_run = time.perf_counter()
        if a.one_server:
            # the bombs in turn, repeat after repeat; the honest mesh after them all (what it leaves in the
            # server's memory would otherwise count towards the bombs' peaks)
            order = [(rep, u) for rep in range(a.repeats) for u in ups if u.name != "honest"]
            order += [(rep, u) for rep in range(a.repeats) for u in ups if u.name == "honest"]
            serve_and_measure(order, env, s.parse_workers, work / "data", a, rows)
        else:
            for u in ups:
                print(f"{u.name}:", flush=True)
                serve_and_measure([(rep, u) for rep in range(a.repeats)], env, s.parse_workers, work / "data", a,
                                  rows)
        print(f"measured in {time.perf_counter() - t_run:.0f} s")

        print(f"\n{len(ups)} uploads x {a.repeats}, load {a.load}, "
              f"{'one server' if a.one_server else 'a fresh server for each upload'}; expanded-size bound "
              f"{s.max_file_expanded_mb:g} MiB; MiB, median [min–max] over the repeats")
        print("| upload | answer | s | server before | peak server | worker before | peak worker | peak total | "
              "server / bound | growth / bound | peer upload ms: during (quiet) | health ms: during (quiet) |")
        print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        for name, rs in rows.items():
            answers = sorted({f"{r.status} {r.code}" for r in rs})
            peak_s = [r.window.server / MIB for r in rs]
            grow = [(r.window.server - r.window.server_before) / limit for r in rs]
            pu = [x for r in rs for x in r.peer_up]
            qu = [x for r in rs for x in r.quiet_up]
            ph = [x for r in rs for x in r.peer_health]
            qh = [x for r in rs for x in r.quiet_health]
            print(f"| {name} | {', '.join(answers)} | {spread([r.seconds for r in rs], '.2f')} | "
                  f"{spread([r.window.server_before / MIB for r in rs])} | {spread(peak_s)} | "
                  f"{spread([r.window.child_before / MIB for r in rs])} | "
                  f"{spread([r.window.child / MIB for r in rs])} | {spread([r.window.total / MIB for r in rs])} | "
                  f"{max(peak_s) * MIB / limit:.2f} | {max(grow):.2f} | {med(pu)} ({med(qu)}) | "
                  f"{med(ph)} ({med(qh)}) |")
        bombs = {n: rs for n, rs in rows.items() if n != "honest"}
        if bombs:
            worst = max(r.window.server for rs in bombs.values() for r in rs)
            grow = max((r.window.server - r.window.server_before) / limit for rs in bombs.values() for r in rs)
            print(f"\nbombs: largest server RSS {worst / MIB:.0f} MiB = {worst / limit:.2f} x the bound (target "
                  f"<= 1.5: {'met' if worst <= 1.5 * limit else 'NOT met'}); largest growth {grow:.2f} x the bound")
            accepted = [n for n, rs in bombs.items() if any(r.status == 201 for r in rs)]
            if accepted:
                print(f"bombs accepted (201): {', '.join(accepted)}")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
