"""geoprox.native answers equal geoproxd's, to the bit, on the same graph file.

Usage: native_daemon_test.py GEOPROXD REPO_ROOT MODULE_DIR (ctest runs it with the interpreter the
module was built for, MODULE_DIR being <build>/python). Exits 77 with one line when the module
was not built (sanitizer builds, no pybind11 or numpy).

The module reads data/meshes/spot.obj, builds a small graph and saves it; geoproxd serves that
file (it must map it, not rebuild it); the module opens the same file (for the mesh file and for
the mesh as arrays). Over a few hundred random pairs of vertices, face points and positions to
snap, distance, exact_distance, matrix, path and field from the module are compared with ==
against the daemon's JSON replies (JSON numbers parse to the same float64; null is NaN). Errors
map to the module's exception classes with the core's reason.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

if len(sys.argv) != 4:
    sys.exit("usage: native_daemon_test.py GEOPROXD REPO_ROOT MODULE_DIR")
GEOPROXD = sys.argv[1]
ROOT, MODULE_DIR = Path(sys.argv[2]).resolve(), Path(sys.argv[3]).resolve()
if not list((MODULE_DIR / "geoprox").glob("native*.so")):
    print(f"SKIP: geoprox.native was not built in {MODULE_DIR} (sanitizer build, or no "
          "pybind11/numpy)")
    sys.exit(77)
sys.path.insert(0, str(MODULE_DIR))

import numpy as np  # noqa: E402

from geoprox import native  # noqa: E402

SPOT = ROOT / "data" / "meshes" / "spot.obj"
PAIRS = 300
checks = 0


def check(condition: bool, message: str) -> None:
    global checks
    if not condition:
        raise AssertionError(message)
    checks += 1


def same(a: float, b: float | None) -> bool:
    """a (module) == b (daemon), NaN standing for null."""
    if b is None:
        return math.isnan(a)
    return a == b


class Daemon:
    def __init__(self, root: Path) -> None:
        self.root = root
        config = {
            "bind": "127.0.0.1", "port": 0, "admin_port": 0, "http_port": 0,
            "compute_threads": 2, "build_threads": 2, "data_dir": "data", "graph_dir": "graphs",
            "log_level": "warn",
            "meshes": [{"id": "spot", "mesh": "spot.obj", "graph": "spot.geoprox"}],
        }
        (root / "geoproxd.json").write_text(json.dumps(config))
        self.log = open(root / "geoproxd.log", "wb")
        port_file = root / "port.json"
        self.process = subprocess.Popen(
            [GEOPROXD, "--config", str(root / "geoproxd.json"), "--port-file", str(port_file)],
            stdout=self.log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 60
        while True:
            if self.process.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("geoproxd did not start:\n" + self.output())
            try:
                self.port = int(json.loads(port_file.read_text())["port"])
                break
            except (OSError, ValueError, KeyError):
                time.sleep(0.02)
        self.sock = socket.create_connection(("127.0.0.1", self.port))
        self.reader = self.sock.makefile("rb")
        self.next_id = 0

    def output(self) -> str:
        self.log.flush()
        return (self.root / "geoproxd.log").read_text(errors="replace")

    def call(self, method: str, **params):
        self.next_id += 1
        line = json.dumps({"jsonrpc": "2.0", "id": self.next_id, "method": method,
                           "params": params})
        self.sock.sendall(line.encode() + b"\n")
        reply = json.loads(self.reader.readline())
        return reply.get("result"), reply.get("error")

    def wait_ready(self) -> None:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            result, _ = self.call("mesh.list")
            state = result["meshes"][0]["state"]
            if state == "ready":
                return
            if state == "failed":
                raise RuntimeError(f"spot failed: {result['meshes'][0]}")
            time.sleep(0.05)
        raise RuntimeError("spot not ready within 120 s")

    def stop(self) -> None:
        self.reader.close()
        self.sock.close()
        self.process.send_signal(signal.SIGTERM)
        try:
            self.process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self.log.close()


def wire(kind: str, points, i: int) -> dict:
    """Point i of `points` (given in the module's form `kind`) as a protocol point object."""
    if kind == "vertex":
        return {"vertex": int(points[i])}
    if kind == "face":
        faces, bary = points
        return {"face": int(faces[i]), "bary": [float(x) for x in bary[i]]}
    return {"position": [float(x) for x in points[i]]}


def take(kind: str, points, index: np.ndarray):
    if kind == "face":
        return points[0][index], points[1][index]
    return points[index]


def main() -> None:
    tmp = Path(tempfile.mkdtemp(prefix="geoprox-native-"))
    daemon = None
    try:
        (tmp / "data").mkdir()
        (tmp / "graphs").mkdir()
        shutil.copy(SPOT, tmp / "data" / "spot.obj")
        V, F = native.read_mesh(tmp / "data" / "spot.obj")
        check(V.shape == (2930, 3) and V.dtype == np.float64, f"V {V.shape} {V.dtype}")
        check(F.shape == (5856, 3) and F.min() == 0 and F.max() == 2929, f"F {F.shape}")

        built = native.Graph.build(V, F, samples=400, neighbors=12)
        check(built.num_samples >= 400 and built.path_on_disk is None, "built graph")
        graph_path = tmp / "graphs" / "spot.geoprox"
        built.save(graph_path)
        check(not list((tmp / "graphs").glob("*.tmp-*")), "no temporary left by save")
        before = os.stat(graph_path)

        daemon = Daemon(tmp)
        daemon.wait_ready()
        after = os.stat(graph_path)
        check((after.st_ino, after.st_mtime_ns) == (before.st_ino, before.st_mtime_ns),
              "geoproxd mapped the module's graph file instead of rebuilding it")

        g = native.Graph.open(graph_path, tmp / "data" / "spot.obj")
        g_arrays = native.Graph.open(graph_path, (V, F))
        check(g.path_on_disk == str(graph_path) and g.num_vertices == 2930, "opened graph")

        rng = np.random.default_rng(42)
        faces = rng.integers(0, len(F), PAIRS)
        bary = rng.dirichlet([1.0, 1.0, 1.0], PAIRS)
        on_surface = np.einsum("ij,ijk->ik", bary, V[F[faces]])
        normals = np.cross(V[F[faces, 1]] - V[F[faces, 0]], V[F[faces, 2]] - V[F[faces, 0]])
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        forms = {
            "vertex": rng.integers(0, len(V), PAIRS),
            "face": (faces, bary),
            "position": on_surface + 1e-3 * normals * rng.uniform(-1, 1, (PAIRS, 1)),
        }
        kinds = list(forms)

        # distance and exact_distance, for every combination of forms.
        for ks in kinds:
            for kt in kinds:
                s, t = forms[ks], forms[kt]
                t_perm = take(kt, t, rng.permutation(PAIRS))
                d, exact = g.distance(s, t_perm, with_exact=True)
                d_arrays = g_arrays.distance(s, t_perm, threads=1)
                check(np.array_equal(d, d_arrays, equal_nan=True),
                      f"{ks}->{kt}: the graph opened with arrays differs")
                for i in range(0, PAIRS, 3 if ks == kt else 10):
                    result, error = daemon.call("geodesic.distance", mesh="spot",
                                                source=wire(ks, s, i), target=wire(kt, t_perm, i))
                    if error:
                        raise AssertionError(f"daemon error {error}")
                    check(same(float(d[i]), result["distance"]) and
                          bool(exact[i]) == result["exact"],
                          f"{ks}->{kt} pair {i}: module {d[i]} {exact[i]}, daemon {result}")
                if ks == kt:
                    sub = np.arange(0, PAIRS, 25)
                    ex = g.exact_distance(take(ks, s, sub), take(kt, t_perm, sub))
                    for j, i in enumerate(sub):
                        result, error = daemon.call(
                            "geodesic.distance", mesh="spot", exact=True,
                            source=wire(ks, s, int(i)), target=wire(kt, t_perm, int(i)))
                        check(error is None and same(float(ex[j]), result["distance"]),
                              f"exact {ks} pair {i}: module {ex[j]}, daemon {result} {error}")
                        check(ex[j] <= d[i] + 1e-12 * d[i], "exact above the graph's answer")

        # matrix: mixed forms, rows split over threads in the module, one call in the daemon.
        for ks, kt in (("face", "face"), ("vertex", "position"), ("position", "face")):
            s = take(ks, forms[ks], np.arange(40))
            t = take(kt, forms[kt], np.arange(100, 130))
            m = g.matrix(s, t, threads=2)
            m1 = g.matrix(s, t, threads=1)
            check(m.shape == (40, 30) and np.array_equal(m, m1, equal_nan=True),
                  "matrix differs between 1 and 2 threads")
            result, error = daemon.call(
                "geodesic.matrix", mesh="spot",
                sources=[wire(ks, forms[ks], i) for i in range(40)],
                targets=[wire(kt, forms[kt], i) for i in range(100, 130)])
            check(error is None, f"matrix error {error}")
            for i in range(40):
                for j in range(30):
                    check(same(float(m[i, j]), result["distances"][i][j]),
                          f"matrix {ks}x{kt} [{i}][{j}]: {m[i, j]} vs {result['distances'][i][j]}")
            d = g.distance(take(ks, s, np.arange(40)), take(kt, t, np.zeros(40, dtype=int)))
            # The matrix shares its searches among targets: equal to distance() up to rounding.
            check(np.allclose(d, m[:, 0], rtol=1e-12, atol=0, equal_nan=True),
                  f"matrix column {ks}x{kt} differs from distance()")

        # path: every point, face, barycentrics and position.
        s, t = forms["face"], take("vertex", forms["vertex"], rng.permutation(PAIRS))
        paths = g.path(s, t)
        check(len(paths) == PAIRS, "one path per pair")
        for i in range(0, PAIRS, 15):
            result, error = daemon.call("geodesic.path", mesh="spot", source=wire("face", s, i),
                                        target=wire("vertex", t, i))
            check(error is None, f"path error {error}")
            p = paths[i]
            check(p.distance == result["distance"] and p.exact == result["exact"],
                  f"path {i}: {p.distance} vs {result['distance']}")
            check(len(p) == len(result["points"]), f"path {i}: {len(p)} points vs "
                  f"{len(result['points'])}")
            for k, point in enumerate(result["points"]):
                check(int(p.faces[k]) == point["face"] and
                      p.bary[k].tolist() == point["bary"] and
                      p.xyz[k].tolist() == point["position"], f"path {i} point {k}")

        # field: one source, several with a cutoff (null and NaN where not reached).
        for sources, cutoff in ((take("face", forms["face"], np.arange(1)), None),
                                (take("vertex", forms["vertex"], np.arange(3)), 0.3)):
            kw = {} if cutoff is None else {"cutoff": cutoff}
            field, nearest = g.field(sources, with_nearest=True, **kw)
            n = len(sources[0]) if isinstance(sources, tuple) else len(sources)
            kind = "face" if isinstance(sources, tuple) else "vertex"
            result, error = daemon.call("geodesic.field", mesh="spot",
                                        sources=[wire(kind, sources, i) for i in range(n)], **kw)
            check(error is None, f"field error {error}")
            check(field.shape == (2930,), "field shape")
            check(all(same(float(a), b) for a, b in zip(field, result["distances"])),
                  f"field with {n} sources differs from the daemon's")
            if cutoff is not None:
                check(bool(np.isnan(field).any()), "the cutoff leaves vertices unreached")
                check([None if k < 0 else int(k) for k in nearest] == result["nearest_source"],
                      "nearest sources differ")

        # Python threads querying one graph at once (each call releases the GIL): the pool
        # hands each its own scratch, and the answers are the serial ones.
        s = take("face", forms["face"], np.arange(60))
        t = take("position", forms["position"], np.arange(60))
        serial = g.matrix(s, t, threads=1)
        results: list = [None] * 4

        def work(k: int) -> None:
            results[k] = g.matrix(s, t, threads=1)

        workers = [threading.Thread(target=work, args=(k,)) for k in range(4)]
        for w in workers:
            w.start()
        for w in workers:
            w.join()
        check(all(np.array_equal(r, serial, equal_nan=True) for r in results),
              "matrices computed by concurrent Python threads differ from the serial one")

        # Errors: the core's typed errors as Python exceptions with the reason.
        for call, reason in (
                (lambda: g.distance(np.array([0]), np.array([99999])), "VertexOutOfRange"),
                (lambda: g.matrix((np.array([99999]), np.array([[1.0, 0, 0]])), np.array([0])),
                 "FaceOutOfRange"),
                (lambda: g.distance((np.array([0]), np.array([[0.5, 0.2, 0.2]])),
                                    np.array([0])), "BadBarycentric"),
                (lambda: g.distance(np.array([[1e6, 0.0, 0.0]]), np.array([0])),
                 "TooFarFromSurface")):
            try:
                call()
            except native.InvalidInput as e:
                check(e.reason == reason and reason in str(e), f"{e.reason} != {reason}: {e}")
            else:
                raise AssertionError(f"no {reason}")
        other = tmp / "other.obj"
        other.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
        try:
            native.Graph.open(graph_path, other)
        except native.FileError as e:
            check(e.reason == "MeshMismatch" and isinstance(e, OSError), str(e))
        else:
            raise AssertionError("a graph file opened for another mesh")
        try:
            native.read_mesh(tmp / "missing.obj")
        except native.FileError as e:
            check(e.reason == "FileNotFound", str(e))
        else:
            raise AssertionError("read a missing mesh")
        try:
            g.distance(np.array([0.5]), np.array([0]))
        except TypeError as e:
            check("vertex ids" in str(e), str(e))
        else:
            raise AssertionError("float ids accepted")
    finally:
        if daemon is not None:
            daemon.stop()
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"native_daemon_test: {checks} checks passed")


main()
