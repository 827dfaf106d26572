"""Cost of a distance matrix in-process (geoprox.native) against the C++ matrix, and through
the daemon. Not a test: it only measures.

    /usr/bin/python3 bench/python_matrix.py --build BUILD [--mesh MESH] [--graph GRAPH]
        [--points 1000] [--rounds 3] [--threads 1,2] [--seed 1] [--daemon [--daemon-rounds K]]

BUILD is a Release build with geoprox.native (BUILD/python) and the benches (BUILD/bench/
matrix_bench); MESH defaults to $GEOPROX_SHARED_MESHES/lucy.obj; GRAPH (default
BUILD/bench-graphs/<mesh>.geoprox) is built with the defaults of `geoprox build` when missing.
The points are N random face points (uniform face, uniform barycentrics, seeded), written to a
file that matrix_bench reads; the matrix is every point to every point. Each round runs, for
each thread count, the C++ matrix (matrix_bench, one round, its own timing of the matrix
calls) then geoprox.native's matrix() (timed around the call: argument conversion and the
result array included), so that the two alternate in one session; the report gives each
one's median over the rounds, per pair, the ratio, and checks that both computed the same
matrix (the sequential sum of the finite entries). --daemon adds geoproxd (BUILD/server/
geoproxd, compute_threads 2) on the same graph file: one geodesic.matrix over TCP per round,
timed from sending the request to the parsed reply (in the first K rounds only with
--daemon-rounds K).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", required=True, type=Path)
    parser.add_argument("--mesh", type=Path)
    parser.add_argument("--graph", type=Path)
    parser.add_argument("--points", type=int, default=1000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--threads", default="1,2")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--daemon", action="store_true")
    parser.add_argument("--daemon-rounds", type=int, help="rounds with the daemon (default all)")
    args = parser.parse_args()
    build = args.build.resolve()
    sys.path.insert(0, str(build / "python"))
    import numpy as np
    from geoprox import native

    mesh = args.mesh
    if mesh is None:
        shared = os.environ.get("GEOPROX_SHARED_MESHES")
        if not shared:
            sys.exit("python_matrix.py: give --mesh or set GEOPROX_SHARED_MESHES")
        mesh = Path(shared) / "lucy.obj"
    mesh = mesh.resolve()
    graph_path = args.graph or build / "bench-graphs" / (mesh.stem + ".geoprox")
    V, F = native.read_mesh(mesh)
    if not graph_path.exists():
        graph_path.parent.mkdir(parents=True, exist_ok=True)
        start = time.perf_counter()
        native.Graph.build(V, F).save(graph_path, source_mesh=str(mesh))
        print(f"built {graph_path} in {time.perf_counter() - start:.1f} s")
    graph = native.Graph.open(graph_path, mesh)
    print(f"mesh {mesh.name}: {graph.num_vertices} vertices, {graph.num_faces} faces, "
          f"{graph.num_samples} samples; {args.points} x {args.points} face points, "
          f"seed {args.seed}")

    rng = np.random.default_rng(args.seed)
    faces = rng.integers(0, len(F), args.points)
    bary = rng.dirichlet([1.0, 1.0, 1.0], args.points)
    tmp = Path(tempfile.mkdtemp(prefix="python-matrix-"))
    points_file = tmp / "points.txt"
    points_file.write_text("".join(f"{int(f)} {b[0]!r} {b[1]!r} {b[2]!r}\n"
                                   for f, b in zip(faces, bary.tolist())))
    points = (faces, bary)
    pairs = args.points * args.points
    thread_counts = [int(t) for t in args.threads.split(",")]
    cpp_ms = {t: [] for t in thread_counts}
    py_ms = {t: [] for t in thread_counts}
    daemon_ms: list[float] = []
    daemon = Daemon(build, mesh, graph_path, tmp) if args.daemon else None
    try:
        for round_index in range(args.rounds):
            for t in thread_counts:
                done = subprocess.run(
                    [str(build / "bench" / "matrix_bench"), str(mesh), str(graph_path),
                     str(points_file), "--rounds", "1", "--threads", str(t)],
                    capture_output=True, text=True, check=True)
                found = re.search(r"median_ms (\S+) checksum (\S+)", done.stdout)
                cpp_ms[t].append(float(found.group(1)))
                cpp_checksum = float(found.group(2))
                start = time.perf_counter()
                M = graph.matrix(points, points, threads=t)
                py_ms[t].append((time.perf_counter() - start) * 1e3)
                checksum = sum(x for x in M.ravel().tolist() if x == x)
                if checksum != cpp_checksum:
                    sys.exit(f"the matrices differ: checksum {checksum!r} in Python, "
                             f"{cpp_checksum!r} in C++")
                print(f"round {round_index + 1}, {t} thread(s): C++ {cpp_ms[t][-1]:.0f} ms, "
                      f"geoprox.native {py_ms[t][-1]:.0f} ms")
            if daemon and (args.daemon_rounds is None or round_index < args.daemon_rounds):
                daemon_ms.append(daemon.matrix(faces, bary))
                print(f"round {round_index + 1}, daemon: {daemon_ms[-1]:.0f} ms")
    finally:
        if daemon:
            daemon.stop()
        shutil.rmtree(tmp, ignore_errors=True)

    print("\n| path | threads | median ms | us per pair | / C++ |")
    print("| --- | --- | --- | --- | --- |")
    for t in thread_counts:
        c, p = statistics.median(cpp_ms[t]), statistics.median(py_ms[t])
        print(f"| C++ matrix_bench | {t} | {c:.0f} | {c * 1e3 / pairs:.3f} | 1 |")
        print(f"| geoprox.native | {t} | {p:.0f} | {p * 1e3 / pairs:.3f} | {p / c:.3f} |")
    if daemon_ms:
        d, c = statistics.median(daemon_ms), statistics.median(cpp_ms[thread_counts[0]])
        print(f"| geoproxd over TCP (JSON) | 1 per request | {d:.0f} | {d * 1e3 / pairs:.3f} | "
              f"{d / c:.3f} (vs {thread_counts[0]} thread C++) |")


class Daemon:
    """geoproxd serving `mesh` from `graph` (mapped, not rebuilt)."""

    def __init__(self, build: Path, mesh: Path, graph: Path, tmp: Path) -> None:
        config = {
            "bind": "127.0.0.1", "port": 0, "admin_port": 0, "http_port": 0,
            "compute_threads": 2, "build_threads": 1, "data_dir": str(mesh.parent),
            "graph_dir": str(graph.parent), "log_level": "warn",
            "limits": {"max_line_bytes": 1 << 26, "default_timeout_ms": 1800000,
                       "max_timeout_ms": 1800000, "read_timeout_ms": 1800000},
            "meshes": [{"id": "bench", "mesh": mesh.name, "graph": graph.name}],
        }
        (tmp / "geoproxd.json").write_text(json.dumps(config))
        self.log = open(tmp / "geoproxd.log", "wb")
        port_file = tmp / "port.json"
        self.process = subprocess.Popen(
            [str(build / "server" / "geoproxd"), "--config", str(tmp / "geoproxd.json"),
             "--port-file", str(port_file)], stdout=self.log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 60
        while True:
            if self.process.poll() is not None or time.monotonic() > deadline:
                sys.exit("geoproxd did not start: " + (tmp / "geoproxd.log").read_text())
            try:
                port = int(json.loads(port_file.read_text())["port"])
                break
            except (OSError, ValueError, KeyError):
                time.sleep(0.05)
        self.sock = socket.create_connection(("127.0.0.1", port))
        self.reader = self.sock.makefile("rb")
        while True:
            state = self.call("mesh.list", {})["meshes"][0]["state"]
            if state == "ready":
                break
            if state == "failed" or time.monotonic() > deadline + 240:
                sys.exit(f"the daemon's mesh is {state}")
            time.sleep(0.1)

    def call(self, method: str, params: dict) -> dict:
        request = {"jsonrpc": "2.0", "id": 1, "method": method, "params": params}
        self.sock.sendall(json.dumps(request).encode() + b"\n")
        reply = json.loads(self.reader.readline())
        if "error" in reply:
            sys.exit(f"{method}: {reply['error']}")
        return reply["result"]

    def matrix(self, faces, bary) -> float:
        points = [{"face": int(f), "bary": b} for f, b in zip(faces, bary.tolist())]
        start = time.perf_counter()
        self.call("geodesic.matrix", {"mesh": "bench", "sources": points, "targets": points})
        return (time.perf_counter() - start) * 1e3

    def stop(self) -> None:
        self.reader.close()
        self.sock.close()
        self.process.send_signal(signal.SIGTERM)
        self.process.wait(timeout=30)
        self.log.close()


main()
