"""Tests of the geoprox Python client against a real geoproxd.

The daemon binary comes from the environment variable GEOPROXD (ctest sets it). The module
starts one daemon on an ephemeral TCP port and a free HTTP port with a temporary config and
data directory serving data/meshes/spot.obj (its graph is built into a temporary directory at start), waits
until spot is ready, and runs every method and error path through the client, once over each
transport: the live test classes run over TCP, and their Http* subclasses at the end over HTTP
(``Client("http://...")``). A few tests use a tiny fake server on 127.0.0.1 instead, where the
daemon cannot be made to misbehave on cue (replies in reverse order, a connection closed
mid-request, a server that never answers). test_http.py has the HTTP transport's own tests.
"""

from __future__ import annotations

import array
import json
import math
import os
import shutil
import signal
import socket
import struct
import subprocess
import tempfile
import threading
import time
import unittest
from pathlib import Path
from typing import Any, Callable, Optional

import geoprox
from geoprox import (
    GeoproxConnectionError,
    GeoproxError,
    GeoproxTimeoutError,
    Reason,
    ServerError,
)

SOURCE_DIR = Path(__file__).resolve().parents[3]
SPOT_OBJ = SOURCE_DIR / "data" / "meshes" / "spot.obj"
TOKEN = "test-token"
QUERY_TOKEN = "test-query-token-0d5e"
# A closed tetrahedron (vertices 0-3) and, apart from it, an open unit square (vertices 4-7).
TWO_COMPONENTS_OBJ = """\
v 0 0 0
v 1 0 0
v 0 1 0
v 0 0 1
v 5 0 0
v 6 0 0
v 6 1 0
v 5 1 0
f 1 3 2
f 1 2 4
f 2 3 4
f 3 1 4
f 5 6 7
f 5 7 8
"""

# Two triangles sharing only their first vertex: a non-manifold vertex that repair splits.
BOWTIE_OBJ = """\
v 0 0 0
v 1 0 0
v 1 1 0
v -1 0 0
v -1 -1 0
f 1 2 3
f 1 4 5
"""
SPOT_VERTICES = 2930
SPOT_FACES = 5856


def free_port() -> int:
    """A port of 127.0.0.1 that was free a moment ago."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Daemon:
    """A geoproxd subprocess on an ephemeral TCP port and a free HTTP port (`http_port`, unless
    given: geoproxd's http_port 0 turns HTTP off), with its config and data in `root`."""

    def __init__(self, binary: str, root: Path, name: str, **config: Any) -> None:
        self.root = root
        self.port_file = root / f"{name}.port.json"
        self.log_path = root / f"{name}.log"
        document = {
            "bind": "127.0.0.1",
            "port": 0,
            "admin_port": 0,
            "http_port": 0,
            "compute_threads": 2,
            "build_threads": 2,
            "data_dir": "data",
            "graph_dir": "graphs",
            "admin_token": TOKEN,
            "log_level": "warn",
            # Small graph: fast to build, also under sanitizers.
            "meshes": [{"id": "spot", "mesh": "meshes/spot.obj", "samples": 400, "neighbors": 12}],
        }
        document.update(config)
        config_path = root / f"{name}.json"
        for attempt in range(3):
            if "http_port" not in config:
                document["http_port"] = free_port()
            config_path.write_text(json.dumps(document, indent=2))
            self.log = open(self.log_path, "wb")
            self.process = subprocess.Popen(
                [binary, "--config", str(config_path), "--port-file", str(self.port_file)],
                stdout=self.log,
                stderr=subprocess.STDOUT,
                env={
                    k: v
                    for k, v in os.environ.items()
                    if k not in ("GEOPROX_ADMIN_TOKEN", "GEOPROX_QUERY_TOKEN")
                },
            )
            try:
                self.port, self.http_port = self._wait_for_ports(timeout=60.0)
                return
            except RuntimeError:
                self.log.close()
                # The free port was taken in the meantime: another one.
                if attempt == 2 or "http_port" in config or "in use" not in self.output():
                    raise

    def _wait_for_ports(self, timeout: float) -> tuple[int, int]:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(
                    f"geoproxd exited with status {self.process.returncode}:\n{self.output()}"
                )
            try:
                ports = json.loads(self.port_file.read_text())
                return int(ports["port"]), int(ports["http_port"])
            except (OSError, ValueError, KeyError):
                time.sleep(0.02)
        raise RuntimeError(f"geoproxd wrote no port file within {timeout} s:\n{self.output()}")

    def output(self) -> str:
        if not self.log.closed:
            self.log.flush()
        return self.log_path.read_text(errors="replace")

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.http_port}"

    def client(self, transport: str = "tcp", **options: Any) -> geoprox.Client:
        """A client over `transport`: "tcp" (the query port) or "http" (the HTTP port)."""
        if transport == "http":
            return geoprox.Client(self.url, **options)
        return geoprox.Client("127.0.0.1", self.port, **options)

    def stop(self) -> int:
        """SIGTERM, then SIGKILL after 20 s; returns the exit status."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.log.close()
        return self.process.returncode


class FakeServer:
    """A one-connection-at-a-time TCP server on 127.0.0.1 whose behaviour per connection is
    `handle(connection, lines)`, where `lines(n)` reads n request lines (parsed JSON)."""

    def __init__(self, handle: Callable[[socket.socket, Callable[[int], list]], None]) -> None:
        self._handle = handle
        self._listener = socket.create_server(("127.0.0.1", 0))
        self.port = self._listener.getsockname()[1]
        self._thread = threading.Thread(target=self._serve, daemon=True)

    def _serve(self) -> None:
        while True:
            try:
                connection, _ = self._listener.accept()
            except OSError:
                return
            with connection:
                reader = connection.makefile("rb")

                def lines(n: int) -> list:
                    return [json.loads(reader.readline()) for _ in range(n)]

                try:
                    self._handle(connection, lines)
                except (OSError, ValueError):
                    pass
                finally:
                    reader.close()  # else the socket stays open until the reader is collected

    def __enter__(self) -> "FakeServer":
        self._thread.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        # Closing a listening socket does not wake a thread blocked in accept(); shutting it
        # down does (Linux), so that a handler that has returned costs no join timeout.
        try:
            self._listener.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self._listener.close()
        self._thread.join(timeout=5)
        if exc[0] is None and self._thread.is_alive():
            raise RuntimeError("the fake server's thread did not stop")


def reply(rid: Any, result: Any) -> bytes:
    return json.dumps({"jsonrpc": "2.0", "id": rid, "result": result}).encode() + b"\n"


def float32(value: float) -> float:
    return struct.unpack("<f", struct.pack("<f", value))[0]


ROOT: Optional[tempfile.TemporaryDirectory] = None
DAEMON: Optional[Daemon] = None


def daemon() -> Daemon:
    """The module's daemon (started by setUpModule)."""
    assert DAEMON is not None
    return DAEMON


def setUpModule() -> None:
    global ROOT, DAEMON
    binary = os.environ.get("GEOPROXD")
    if not binary:
        raise RuntimeError(
            "GEOPROXD is not set: run these tests with GEOPROXD=/path/to/build/server/geoproxd "
            "(ctest sets it)"
        )
    if not os.access(binary, os.X_OK):
        raise RuntimeError(f"GEOPROXD={binary} is not an executable file")
    # Clients read their query token from GEOPROX_TOKEN; the tests choose theirs.
    os.environ.pop("GEOPROX_TOKEN", None)
    ROOT = tempfile.TemporaryDirectory(prefix="geoprox-python-test-")
    root = Path(ROOT.name)
    (root / "data" / "meshes").mkdir(parents=True)
    (root / "graphs").mkdir()
    shutil.copy(SPOT_OBJ, root / "data" / "meshes" / "spot.obj")
    (root / "data" / "meshes" / "two_components.obj").write_text(TWO_COMPONENTS_OBJ)
    (root / "data" / "meshes" / "bowtie.obj").write_text(BOWTIE_OBJ)
    DAEMON = Daemon(binary, root, "main")
    with daemon().client() as client:
        client.wait_ready("spot", timeout=300)


def tearDownModule() -> None:
    if DAEMON is not None:
        status = DAEMON.stop()
        if status != 0:
            print(f"geoproxd exited with status {status}:\n{DAEMON.output()}")
    if ROOT is not None:
        ROOT.cleanup()


class LiveTestCase(unittest.TestCase):
    """A client on the module's daemon for each test, over `transport` ("tcp" or "http")."""

    transport = "tcp"

    def setUp(self) -> None:
        self.client = daemon().client(self.transport, timeout=60.0, admin_token=TOKEN)
        expected = geoprox.HttpClient if self.transport == "http" else geoprox.Client
        self.assertIs(type(self.client), expected)

    def tearDown(self) -> None:
        self.client.close()

    def assertReason(self, error: Optional[GeoproxError], reason: str, code: Optional[int]) -> None:
        assert error is not None
        self.assertEqual(error.reason, reason, str(error))
        self.assertTrue(error.is_reason(reason))
        self.assertEqual(error.code, code)


class QueryTest(LiveTestCase):
    def test_distance_with_every_point_form(self) -> None:
        c = self.client
        forms: list[tuple[str, dict[str, Any]]] = [
            ("v:12", geoprox.vertex(12)),
            ("e:7:0.25", geoprox.edge(7, 0.25)),
            ("f:100:0.2:0.3:0.5", geoprox.face(100, 0.2, 0.3, 0.5)),
            ("s:3", geoprox.sample(3)),
            ("p:0.37,-0.29,0.19", geoprox.position(0.37, -0.29, 0.19)),
        ]
        for text, obj in forms:
            with self.subTest(point=text):
                self.assertEqual(geoprox.parse_point(text), obj)
                by_text = c.distance("spot", "v:0", text)
                by_object = c.distance("spot", geoprox.vertex(0), obj)
                self.assertEqual(by_text["distance"], by_object["distance"])
                self.assertGreater(by_text["distance"], 0.0)
                self.assertIsInstance(by_text["exact"], bool)  # near points: exact anyway
                self.assertEqual(by_text["mesh"], "spot")
                self.assertIsInstance(by_text["mesh_version"], str)
                self.assertEqual(by_text["source"], {"vertex": 0})
                if "position" not in obj:  # positions come back as sent too
                    self.assertEqual(by_text["target"], obj)

    def test_exact_distance(self) -> None:
        approx = self.client.distance("spot", "v:0", "v:1500")
        exact = self.client.distance("spot", "v:0", "v:1500", exact=True)
        self.assertTrue(exact["exact"])
        self.assertLessEqual(exact["distance"], approx["distance"] * (1 + 1e-9))
        self.assertAlmostEqual(
            exact["distance"], approx["distance"], delta=0.05 * exact["distance"]
        )

    def test_path(self) -> None:
        result = self.client.path("spot", "v:0", "e:208:0.5")
        distance = self.client.distance("spot", "v:0", "e:208:0.5")["distance"]
        self.assertAlmostEqual(result["distance"], distance, places=12)
        points = result["points"]
        self.assertGreaterEqual(len(points), 2)
        for point in points:
            self.assertEqual(set(point), {"face", "bary", "position"})
            self.assertLess(point["face"], SPOT_FACES)
            self.assertAlmostEqual(sum(point["bary"]), 1.0, places=9)
            self.assertEqual(len(point["position"]), 3)
        length = sum(math.dist(a["position"], b["position"]) for a, b in zip(points, points[1:]))
        self.assertAlmostEqual(length, result["distance"], delta=1e-6)

    def test_field_encodings_agree(self) -> None:
        c = self.client
        as_json = c.field("spot", "v:0")
        as_f32 = c.field("spot", "v:0", encoding="f32le-base64")
        self.assertEqual(as_json["encoding"], "json")
        self.assertEqual(as_f32["encoding"], "f32le-base64")
        self.assertEqual(as_json["vertices"], SPOT_VERTICES)
        self.assertEqual(as_json["reached"], SPOT_VERTICES)
        self.assertIsNone(as_json["cutoff"])
        if geoprox.HAVE_NUMPY:
            import numpy

            self.assertIsInstance(as_f32["distances"], numpy.ndarray)
            self.assertEqual(as_f32["distances"].dtype, numpy.float32)
        else:
            self.assertIsInstance(as_f32["distances"], array.array)
            self.assertEqual(as_f32["distances"].typecode, "f")
        self.assertEqual(len(as_f32["distances"]), SPOT_VERTICES)
        self.assertEqual(as_json["distances"][0], 0.0)
        for i, (d64, d32) in enumerate(zip(as_json["distances"], as_f32["distances"])):
            self.assertEqual(float(d32), float32(d64), f"vertex {i}: {d32} vs {d64}")
            self.assertLessEqual(abs(float(d32) - d64), 6e-8 * d64 + 1e-30)
        # Without numpy, whatever is installed.
        plain = daemon().client(self.transport, use_numpy=False)
        with plain:
            decoded = plain.field("spot", "v:0", encoding="f32le-base64")["distances"]
        self.assertIsInstance(decoded, array.array)
        self.assertEqual(list(decoded), [float(d) for d in as_f32["distances"]])

    def test_f64_encodings_are_the_json_numbers_without_numpy(self) -> None:
        with daemon().client(self.transport, use_numpy=False) as plain:
            sources = ["v:0", "f:100:0.2:0.3:0.5"]
            as_json = plain.field("spot", sources, cutoff=0.3)
            as_f64 = plain.field("spot", sources, cutoff=0.3, encoding="f64le-base64")
            self.assertEqual(as_f64["encoding"], "f64le-base64")
            self.assertIsInstance(as_f64["distances"], array.array)
            self.assertEqual(as_f64["distances"].typecode, "d")
            want = [math.inf if d is None else d for d in as_json["distances"]]
            self.assertEqual([struct.pack("<d", d) for d in as_f64["distances"]],
                             [struct.pack("<d", d) for d in want])
            self.assertIn(math.inf, want)
            unreached = [geoprox.NOT_REACHED_SOURCE if k is None else k
                         for k in as_json["nearest_source"]]
            self.assertEqual(list(as_f64["nearest_source"]), unreached)
            matrix = plain.call("geodesic.matrix", {"mesh": "spot", "sources": sources,
                                                    "targets": ["v:2", "v:3", "s:7"],
                                                    "encoding": "f64le-base64"})
            rows = plain.matrix("spot", sources, ["v:2", "v:3", "s:7"])["distances"]
        self.assertEqual([list(row) for row in matrix["distances"]], rows)
        if not geoprox.HAVE_NUMPY:
            with self.assertRaisesRegex(RuntimeError, "as_array needs numpy"):
                self.client.matrix("spot", ["v:0"], ["v:1"], as_array=True)
            with self.assertRaisesRegex(RuntimeError, r"geoprox.faces\(\) needs numpy"):
                geoprox.faces([0], [[1, 0, 0]])

    def test_field_several_sources_with_cutoff(self) -> None:
        c = self.client
        sources: list[geoprox.Point] = ["v:0", geoprox.vertex(1500)]
        as_json = c.field("spot", sources, cutoff=0.3)
        as_f32 = c.field("spot", sources=sources, cutoff=0.3, encoding="f32le-base64")
        self.assertEqual(as_json["cutoff"], 0.3)
        self.assertLess(as_json["reached"], SPOT_VERTICES)
        self.assertEqual(as_json["reached"], as_f32["reached"])
        self.assertEqual(sum(d is not None for d in as_json["distances"]), as_json["reached"])
        pairs = zip(
            as_json["distances"],
            as_f32["distances"],
            as_json["nearest_source"],
            as_f32["nearest_source"],
        )
        for d64, d32, n_json, n_u32 in pairs:
            if d64 is None:
                self.assertEqual(float(d32), math.inf)
                self.assertIsNone(n_json)
                self.assertEqual(int(n_u32), geoprox.NOT_REACHED_SOURCE)
            else:
                self.assertLessEqual(d64, 0.3)
                self.assertEqual(float(d32), float32(d64))
                self.assertIn(n_json, (0, 1))
                self.assertEqual(int(n_u32), n_json)
        self.assertEqual(as_json["nearest_source"][0], 0)
        self.assertEqual(as_json["nearest_source"][1500], 1)

    def test_matrix(self) -> None:
        sources: list[geoprox.Point] = ["v:0", "e:7:0.25"]
        targets: list[geoprox.Point] = [
            "v:2",
            "f:100:0.2:0.3:0.5",
            "s:3",
            geoprox.position(0.37, -0.29, 0.19),
        ]
        result = self.client.matrix("spot", sources, targets)
        self.assertEqual((result["sources"], result["targets"], result["unreachable"]), (2, 4, 0))
        self.assertEqual(len(result["distances"]), 2)
        for i, s in enumerate(sources):
            self.assertEqual(len(result["distances"][i]), 4)
            for j, t in enumerate(targets):
                expected = self.client.distance("spot", s, t)["distance"]
                self.assertAlmostEqual(result["distances"][i][j], expected, places=12)

    def test_batch(self) -> None:
        r = geoprox.request
        results = self.client.batch(
            [
                r.distance("spot", "v:0", "v:1"),
                r.distance("spot", "v:0", "f:9999:1:0:0"),
                r.field("spot", "v:0", encoding="f32le-base64"),
                ("mesh.info", {"mesh": "spot"}),
                {"method": "server.health"},
            ]
        )
        self.assertEqual(len(results), 5)
        self.assertEqual(
            results[0]["distance"], self.client.distance("spot", "v:0", "v:1")["distance"]
        )
        self.assertIsInstance(results[1], ServerError)
        self.assertReason(results[1], Reason.FACE_OUT_OF_RANGE, -32602)
        self.assertEqual(len(results[2]["distances"]), SPOT_VERTICES)
        self.assertNotIsInstance(results[2]["distances"], (str, list))
        self.assertEqual(results[3]["mesh"], "spot")
        self.assertTrue(results[4]["ready"])
        with self.assertRaises(ServerError) as caught:  # structural problem: the whole batch
            self.client.batch([])
        self.assertReason(caught.exception, Reason.INVALID_PARAMS, -32602)


class InfoTest(LiveTestCase):
    def test_mesh_list_and_info(self) -> None:
        meshes = {m["id"]: m for m in self.client.mesh_list()["meshes"]}
        spot = meshes["spot"]
        self.assertEqual(spot["state"], "ready")
        self.assertEqual(
            (spot["vertices"], spot["faces"], spot["samples"]), (SPOT_VERTICES, SPOT_FACES, 400)
        )
        info = self.client.mesh_info("spot")
        self.assertEqual(info["mesh"], "spot")
        self.assertEqual(info["mesh_version"], spot["mesh_version"])
        self.assertEqual(info["edges"], 8784)
        self.assertEqual(info["build"]["samples"], 400)
        self.assertEqual(info["build"]["neighbors"], 12)
        self.assertGreater(info["covering_radius"], 0.0)
        self.assertGreater(info["link_radius"], info["covering_radius"])
        self.assertEqual(info["mesh_file"], "meshes/spot.obj")

    def test_server_info(self) -> None:
        info = self.client.server_info()
        self.assertEqual(info["protocol_version"], 1)
        self.assertTrue(info["admin_enabled"])
        self.assertEqual(info["encodings"], ["json", "f32le-base64", "f64le-base64"])
        self.assertEqual(self.client.max_line_bytes, info["limits"]["max_line_bytes"])
        for method in [
            "geodesic.distance",
            "geodesic.path",
            "geodesic.field",
            "geodesic.matrix",
            "batch",
            "mesh.list",
            "mesh.info",
            "server.info",
            "server.health",
            "server.metrics",
            "admin.register",
            "admin.rebuild",
            "admin.unregister",
            "admin.reload",
        ]:
            self.assertIn(method, info["methods"])

    def test_health_and_metrics(self) -> None:
        health = self.client.health()
        self.assertEqual(health["status"], "ok")
        self.assertTrue(health["ready"])
        self.assertGreaterEqual(health["meshes_ready"], 1)
        self.assertGreater(health["uptime_seconds"], 0)
        self.client.distance("spot", "v:0", "v:1")
        metrics = self.client.metrics()
        self.assertEqual(metrics["format"], "prometheus-text-0.0.4")
        labels = f'transport="{self.transport}",method="geodesic.distance",outcome="ok"'
        self.assertIn(f"geoprox_requests_total{{{labels}}}", metrics["text"])

    def test_timeout_ms_is_sent(self) -> None:
        self.assertTrue(self.client.health(timeout_ms=5000)["ready"])
        many = [f"v:{i}" for i in range(60)]
        with self.assertRaises(ServerError) as caught:
            self.client.matrix("spot", many, many, timeout_ms=1)
        self.assertReason(caught.exception, Reason.DEADLINE_EXCEEDED, -32031)
        self.assertTrue(caught.exception.retryable)


class ErrorTest(LiveTestCase):
    def check(self, reason: str, code: int, call: Callable[[], Any]) -> ServerError:
        with self.assertRaises(ServerError) as caught:
            call()
        self.assertReason(caught.exception, reason, code)
        self.assertFalse(caught.exception.retryable)
        self.assertEqual(caught.exception.data["reason"], reason)
        self.assertTrue(caught.exception.message)
        return caught.exception

    def test_unknown_mesh(self) -> None:
        error = self.check(
            Reason.UNKNOWN_MESH, -32001, lambda: self.client.distance("spott", "v:0", "v:1")
        )
        self.assertIsInstance(error, GeoproxError)
        self.assertIn("spott", str(error))
        self.check(Reason.UNKNOWN_MESH, -32001, lambda: self.client.mesh_info("nope"))

    def test_bad_points(self) -> None:
        d = lambda target: lambda: self.client.distance("spot", "v:0", target)  # noqa: E731
        self.check(Reason.FACE_OUT_OF_RANGE, -32602, d("f:9999:0.2:0.3:0.5"))
        self.check(Reason.FACE_OUT_OF_RANGE, -32602, d(geoprox.face(SPOT_FACES, 1, 0, 0)))
        self.check(Reason.VERTEX_OUT_OF_RANGE, -32602, d("v:99999"))
        self.check(Reason.EDGE_OUT_OF_RANGE, -32602, d("e:99999:0.5"))
        self.check(Reason.SAMPLE_OUT_OF_RANGE, -32602, d("s:400"))
        self.check(Reason.BAD_BARYCENTRIC, -32602, d("f:5:0.2:0.3:0.6"))
        self.check(Reason.BAD_EDGE_PARAMETER, -32602, d(geoprox.edge(7, 1.5)))
        self.check(Reason.BAD_POINT, -32602, d("x:1"))
        self.check(Reason.BAD_POINT, -32602, d({"vertex": 1, "face": 2}))

    def test_bad_requests(self) -> None:
        self.check(Reason.UNKNOWN_METHOD, -32601, lambda: self.client.call("geodesic.distances"))
        self.check(
            Reason.INVALID_PARAMS,
            -32602,
            lambda: self.client.call(
                "geodesic.distance",
                {"mesh": "spot", "source": "v:0", "target": "v:1", "max_distance": 1},
            ),
        )
        self.check(
            Reason.INVALID_PARAMS, -32602, lambda: self.client.field("spot", "v:0", encoding="f16")
        )
        error = self.check(
            Reason.TOO_LARGE,
            -32020,
            lambda: self.client.call("server.health", {"pad": "x" * (2 << 20)}),
        )
        if self.transport == "tcp":
            self.assertIn("line", error.message)
        else:
            self.assertEqual(error.http_status, 413)
        self.assertTrue(self.client.health()["ready"])  # the client is still usable
        with self.assertRaises(TypeError):
            self.client.distance("spot", 0, 1)  # type: ignore[arg-type]
        with self.assertRaises(ValueError):
            self.client.distance("spot", "v:0", {"position": [math.nan, 0, 0]})

    def test_unreachable_and_admin(self) -> None:
        c = self.client
        self.check(Reason.UNAUTHORIZED, -32040, lambda: c.admin_reload(token="wrong"))
        anonymous = daemon().client(self.transport)
        with anonymous:
            self.check(Reason.UNAUTHORIZED, -32040, lambda: anonymous.admin_reload())
        self.check(Reason.MESH_EXISTS, -32004, lambda: c.admin_register("spot", "meshes/spot.obj"))
        self.check(Reason.PATH_NOT_ALLOWED, -32602, lambda: c.admin_register("x", "../etc/passwd"))
        self.check(Reason.NOT_FOUND, -32006, lambda: c.admin_register("x", "meshes/missing.obj"))

        # A graph file of each transport's own: the other's would be loaded, not built.
        graph_file = f"two-{self.transport}.geoprox"
        summary = c.admin_register(
            "two", "meshes/two_components.obj", graph_file=graph_file, build={"samples": 8}
        )
        self.assertEqual(summary["mesh"], "two")
        self.assertIn(summary["state"], ("building", "ready"))
        try:
            (entry,) = c.wait_ready("two", timeout=120)
            self.assertEqual(entry["vertices"], 8)
            self.assertTrue(c.mesh_info("two")["graph_file"].endswith(graph_file))
            self.check(Reason.UNREACHABLE, -32010, lambda: c.distance("two", "v:0", "v:5"))
            self.check(Reason.UNREACHABLE, -32010, lambda: c.path("two", "v:0", "v:5"))
            matrix = c.matrix("two", ["v:0", "v:4"], ["v:1", "v:5"])
            self.assertEqual(matrix["unreachable"], 2)
            self.assertIsNone(matrix["distances"][0][1])
            self.assertIsNone(matrix["distances"][1][0])
            self.assertAlmostEqual(matrix["distances"][0][0], 1.0, places=9)

            old_version = entry["mesh_version"]
            rebuilt = c.admin_rebuild("two", build={"samples": 4})
            self.assertEqual(rebuilt["mesh"], "two")
            (entry,) = c.wait_ready("two", timeout=120)
            self.assertEqual(entry["samples"], 4)
            self.assertNotEqual(entry["mesh_version"], old_version)

            reload = c.admin_reload("two")
            self.assertEqual([m["mesh"] for m in reload["meshes"]], ["two"])
            self.assertIsNone(reload["meshes"][0]["error"])
        finally:
            self.assertEqual(c.admin_unregister("two"), {"mesh": "two", "unregistered": True})
        self.check(Reason.UNKNOWN_MESH, -32001, lambda: c.distance("two", "v:0", "v:1"))

    def test_register_with_repair(self) -> None:
        c = self.client
        c.admin_register("bowtie", "meshes/bowtie.obj", build={"samples": 6}, repair=True)
        try:
            (entry,) = c.wait_ready("bowtie", timeout=120)
            self.assertEqual(entry["vertices"], 6)  # vertex 0 split: its copy is vertex 5
            repair = c.mesh_info("bowtie")["repair"]
            self.assertEqual(repair["vertices_split"], 1)
            self.assertEqual(repair["vertices_added"], 1)
            # Corner 0 of face 1 is the copy, one unit from vertex 3 and apart from vertex 0.
            self.assertEqual(c.distance("bowtie", "f:1:1:0:0", "v:5")["distance"], 0.0)
            self.assertAlmostEqual(c.distance("bowtie", "f:1:1:0:0", "v:3")["distance"], 1.0)
            self.check(Reason.UNREACHABLE, -32010, lambda: c.distance("bowtie", "v:0", "v:3"))
        finally:
            c.admin_unregister("bowtie")


class PipelineTest(LiveTestCase):
    def test_hundred_requests_pipelined(self) -> None:
        with self.client.pipeline() as pipe:
            pending = [pipe.distance("spot", "v:0", f"v:{i}") for i in range(100)]
            self.assertEqual(len(pipe), 100)
            self.assertFalse(pending[0].done())
        self.assertTrue(all(p.done() for p in pending))
        for i, p in enumerate(pending):
            result = p.result()
            self.assertEqual(result["target"], {"vertex": i})
            self.assertEqual(
                result["distance"], self.client.distance("spot", "v:0", f"v:{i}")["distance"]
            )

    def test_errors_fail_alone(self) -> None:
        pipe = self.client.pipeline()
        good = pipe.health()
        bad = pipe.distance("nope", "v:0", "v:1")
        big = pipe.call("server.health", {"pad": "x" * (2 << 20)})
        field = pipe.field("spot", "v:0", encoding="f32le-base64")
        outcomes = pipe.execute()
        self.assertEqual(len(outcomes), 4)
        self.assertTrue(good.result()["ready"])
        self.assertIsNone(good.exception())
        self.assertReason(bad.exception(), Reason.UNKNOWN_MESH, -32001)
        with self.assertRaises(ServerError):
            bad.result()
        # TCP: null id, matched by size; HTTP: a body over the limit, sent alone.
        self.assertReason(big.exception(), Reason.TOO_LARGE, -32020)
        self.assertEqual(len(field.result()["distances"]), SPOT_VERTICES)
        self.assertIs(outcomes[1], bad.exception())
        self.assertEqual(len(pipe), 0)  # the pipeline can be used again
        again = pipe.mesh_info("spot")
        pipe.execute()
        self.assertEqual(again.result()["mesh"], "spot")

    def test_call_many(self) -> None:
        r = geoprox.request
        results = self.client.call_many([r.distance("spot", "v:0", "v:1"), r.health()])
        self.assertEqual(results[0]["target"], {"vertex": 1})
        with self.assertRaises(ServerError):
            self.client.call_many([r.health(), r.mesh_info("nope")])
        mixed = self.client.call_many([r.health(), r.mesh_info("nope")], return_exceptions=True)
        self.assertTrue(mixed[0]["ready"])
        self.assertIsInstance(mixed[1], ServerError)

    def test_result_before_execute(self) -> None:
        pending = self.client.pipeline().health()
        with self.assertRaises(RuntimeError):
            pending.result()


class FakePipelineTest(unittest.TestCase):
    def test_replies_out_of_order_and_sent_before_read(self) -> None:
        # The fake server answers only once it has read all 100 requests, in reverse order:
        # a client that waited for each reply before sending the next would time out.
        def handle(connection: socket.socket, lines: Callable[[int], list]) -> None:
            requests = lines(100)
            connection.sendall(
                b"".join(reply(q["id"], {"echo": q["params"]}) for q in reversed(requests))
            )
            time.sleep(0.5)

        with FakeServer(handle) as server, geoprox.Client(port=server.port, timeout=10) as client:
            with client.pipeline() as pipe:
                pending = [pipe.call("echo", {"n": i}) for i in range(100)]
            self.assertEqual([p.result()["echo"]["n"] for p in pending], list(range(100)))


# The same live tests over the HTTP port (POST /v1/rpc; pipelines as batch arrays).
class HttpQueryTest(QueryTest):
    transport = "http"


class HttpInfoTest(InfoTest):
    transport = "http"


class HttpErrorTest(ErrorTest):
    transport = "http"


class HttpPipelineTest(PipelineTest):
    transport = "http"


class ConnectionTest(unittest.TestCase):
    def test_context_manager_closes_socket(self) -> None:
        with daemon().client() as client:
            self.assertTrue(client.health()["ready"])
            sock = client._sock
            assert sock is not None
            self.assertGreaterEqual(sock.fileno(), 0)
        self.assertEqual(sock.fileno(), -1)
        self.assertTrue(client.closed)
        self.assertFalse(client.connected)
        with self.assertRaises(GeoproxConnectionError) as caught:
            client.health()
        self.assertIsInstance(caught.exception, ConnectionError)

    def test_connection_refused(self) -> None:
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        with self.assertRaises(GeoproxConnectionError) as caught:
            geoprox.Client("127.0.0.1", port, timeout=5)
        self.assertIsInstance(caught.exception, ConnectionError)
        self.assertEqual(caught.exception.reason, Reason.CONNECTION_FAILED)
        self.assertIsNone(caught.exception.code)
        client = geoprox.Client("127.0.0.1", port, connect=False)
        self.assertFalse(client.connected)
        with self.assertRaises(GeoproxTimeoutError):
            client.wait_ready(timeout=0.3, interval=0.05)

    def test_connection_closed_mid_request(self) -> None:
        def handle(connection: socket.socket, lines: Callable[[int], list]) -> None:
            lines(1)  # read the request, then hang up without answering

        with FakeServer(handle) as server, geoprox.Client(port=server.port, timeout=10) as client:
            with self.assertRaises(GeoproxConnectionError) as caught:
                client.health()
            self.assertIsInstance(caught.exception, ConnectionError)
            self.assertEqual(caught.exception.reason, Reason.CONNECTION_CLOSED)
            self.assertTrue(caught.exception.retryable)
            self.assertFalse(client.connected)
            pipe = client.pipeline()
            pending = [pipe.health(), pipe.health()]
            with self.assertRaises(GeoproxConnectionError):
                pipe.execute()
            self.assertTrue(all(isinstance(p.exception(), GeoproxConnectionError) for p in pending))

    def test_client_timeout(self) -> None:
        def handle(connection: socket.socket, lines: Callable[[int], list]) -> None:
            lines(1)
            time.sleep(2.0)  # never answers in time

        with FakeServer(handle) as server, geoprox.Client(port=server.port, timeout=0.2) as client:
            started = time.monotonic()
            with self.assertRaises(GeoproxTimeoutError) as caught:
                client.health()
            # Well before the server hangs up, with room for a loaded machine (ctest -j2).
            self.assertLess(time.monotonic() - started, 1.5)
            self.assertIsInstance(caught.exception, TimeoutError)
            self.assertEqual(caught.exception.reason, Reason.TIMEOUT)

    def test_early_reply_to_a_long_line(self) -> None:
        # geoproxd answers TooLarge after reading max_line_bytes + 1 bytes of a line, while the
        # client may still be sending it: the client must finish the line, or the next request
        # becomes part of it. The pad is larger than loopback's socket buffers, so the reply
        # arrives while most of it is unsent.
        too_large = {
            "code": -32020,
            "message": "request line longer than 1048576 bytes",
            "data": {"reason": "TooLarge", "retryable": False},
        }

        def handle(connection: socket.socket, lines: Callable[[int], list]) -> None:
            received = connection.recv(4096)
            connection.sendall(
                json.dumps({"jsonrpc": "2.0", "id": None, "error": too_large}).encode() + b"\n"
            )
            time.sleep(0.2)  # the reply is read before the line is sent
            while received.count(b"\n") < 2:
                chunk = connection.recv(1 << 20)
                if not chunk:
                    return
                received += chunk
            second = json.loads(received.split(b"\n")[1])
            connection.sendall(reply(second["id"], {"ready": True}))
            time.sleep(0.5)

        with FakeServer(handle) as server, geoprox.Client(port=server.port, timeout=30) as client:
            with self.assertRaises(ServerError) as caught:
                client.call("server.health", {"pad": "x" * (32 << 20)})
            self.assertEqual(caught.exception.reason, Reason.TOO_LARGE)
            self.assertTrue(client.health()["ready"])

        # A server that answers and then hangs up before the line is sent: the answer stands
        # (not a connection error), and the next request opens a new connection.
        def answer_and_hang_up(connection: socket.socket, lines: Callable[[int], list]) -> None:
            received = connection.recv(4096)
            if received.startswith(b'{"jsonrpc":"2.0","id":') and b"pad" not in received:
                (request,) = [json.loads(received.split(b"\n")[0])]
                connection.sendall(reply(request["id"], {"ready": True}))
                time.sleep(0.5)
                return
            connection.sendall(
                json.dumps({"jsonrpc": "2.0", "id": None, "error": too_large}).encode() + b"\n"
            )
            connection.shutdown(socket.SHUT_RDWR)

        with FakeServer(answer_and_hang_up) as server:
            with geoprox.Client(port=server.port, timeout=30) as client:
                with self.assertRaises(ServerError) as caught:
                    client.call("server.health", {"pad": "x" * (32 << 20)})
                self.assertEqual(caught.exception.reason, Reason.TOO_LARGE)
                self.assertFalse(client.connected)
                self.assertTrue(client.health()["ready"])

    def test_late_reply_is_dropped(self) -> None:
        # A fake server, so that the reply is late whatever the machine's speed: it answers the
        # first request after the client gave up on it, just before the next request's reply,
        # which is then the first line the client reads. (A real daemon's exact distance took
        # 1.4 ms against a 1 ms timeout: a faster host would have answered in time.)
        def handle(connection: socket.socket, lines: Callable[[int], list]) -> None:
            (slow,) = lines(1)
            time.sleep(1.0)  # the client's timeout (0.05 s) has passed
            connection.sendall(reply(slow["id"], {"distance": 1.0}))
            while True:
                (request,) = lines(1)
                connection.sendall(reply(request["id"], {"ready": True}))

        with FakeServer(handle) as server, geoprox.Client(port=server.port, timeout=10) as client:
            sock = client._sock
            with self.assertRaises(GeoproxTimeoutError):
                client.call(
                    "geodesic.distance",
                    {"mesh": "spot", "source": "v:0", "target": "v:1"},
                    timeout=0.05,
                )
            # Same connection; the late reply is recognised by its id and dropped.
            for _ in range(3):
                self.assertEqual(client.health(), {"ready": True})
            self.assertIs(client._sock, sock)

    def test_retries(self) -> None:
        def handle(connection: socket.socket, lines: Callable[[int], list]) -> None:
            while True:
                (first,) = lines(1)
                overloaded = {
                    "code": -32030,
                    "message": "compute queue full",
                    "data": {"reason": "Overloaded", "retryable": True, "retry_after_ms": 20},
                }
                connection.sendall(
                    json.dumps({"jsonrpc": "2.0", "id": first["id"], "error": overloaded}).encode()
                    + b"\n"
                )
                (second,) = lines(1)
                connection.sendall(reply(second["id"], {"ok": True}))

        with FakeServer(handle) as server:
            with geoprox.Client(port=server.port, timeout=5) as client:
                with self.assertRaises(ServerError) as caught:
                    client.health()
                self.assertEqual(caught.exception.reason, Reason.OVERLOADED)
                self.assertTrue(caught.exception.retryable)
                self.assertEqual(caught.exception.retry_after_ms, 20)
                self.assertEqual(client.health(), {"ok": True})
            with geoprox.Client(port=server.port, timeout=5, retries=2) as client:
                started = time.monotonic()
                self.assertEqual(client.health(), {"ok": True})
                self.assertGreaterEqual(time.monotonic() - started, 0.02)

    def test_daemon_closes_idle_connection_then_dies(self) -> None:
        # A second daemon on the same data: the graph of spot is already built, so it loads.
        other = Daemon(
            os.environ["GEOPROXD"], daemon().root, "idle", limits={"read_timeout_ms": 200}
        )
        try:
            with other.client(timeout=30) as client:
                client.wait_ready("spot", timeout=120)
                first = client._sock
                time.sleep(1.0)  # the daemon closes the idle connection (after 0.2 s)
                self.assertTrue(client.health()["ready"])  # on a new connection, transparently
                self.assertIsNot(client._sock, first)
                other.process.kill()
                other.process.wait()
                with self.assertRaises(GeoproxConnectionError) as caught:
                    client.health()
                self.assertIsInstance(caught.exception, ConnectionError)
        finally:
            other.stop()


class QueryTokenTest(unittest.TestCase):
    """A second daemon on the same data with a query token (docs/protocol.md, server.auth)."""

    secured: Optional[Daemon] = None

    @classmethod
    def setUpClass(cls) -> None:
        cls.secured = Daemon(
            os.environ["GEOPROXD"], daemon().root, "secured", query_token=QUERY_TOKEN
        )
        with cls.secured.client(token=QUERY_TOKEN, timeout=30) as client:
            client.wait_ready("spot", timeout=120)

    @classmethod
    def tearDownClass(cls) -> None:
        if cls.secured is not None:
            cls.secured.stop()

    def port(self) -> int:
        assert self.secured is not None
        return self.secured.port

    def test_without_token_only_health_answers(self) -> None:
        with geoprox.Client("127.0.0.1", self.port(), timeout=10) as client:
            self.assertTrue(client.health()["auth_required"])
            for call in (
                lambda: client.distance("spot", "v:0", "v:1"),
                lambda: client.mesh_list(),
                lambda: client.server_info(),
            ):
                with self.assertRaises(ServerError) as caught:
                    call()
                self.assertEqual(caught.exception.reason, Reason.UNAUTHORIZED)
                self.assertEqual(caught.exception.code, -32040)
                self.assertFalse(caught.exception.retryable)
        with daemon().client(timeout=10) as open_client:
            self.assertFalse(open_client.health()["auth_required"])

    def test_token_opens_queries_pipelines_and_batches(self) -> None:
        with daemon().client(timeout=30) as reference:
            expected = reference.distance("spot", "v:0", "f:100:0.2:0.3:0.5")["distance"]
        with geoprox.Client("127.0.0.1", self.port(), timeout=30, token=QUERY_TOKEN) as client:
            self.assertEqual(
                client.distance("spot", "v:0", "f:100:0.2:0.3:0.5")["distance"], expected
            )
            with client.pipeline() as pipe:
                pending = [pipe.distance("spot", "v:0", f"v:{i}") for i in range(1, 20)]
            self.assertTrue(all(p.result()["distance"] > 0 for p in pending))
            (first,) = client.batch([geoprox.request.distance("spot", "v:0", "f:100:0.2:0.3:0.5")])
            self.assertEqual(first["distance"], expected)
            # A new connection (the old one dropped) is authenticated again, transparently.
            first_sock = client._sock
            client._drop()
            self.assertEqual(client.mesh_list()["meshes"][0]["id"], "spot")
            self.assertIsNot(client._sock, first_sock)

    def test_wrong_or_admin_token_is_refused_at_connect(self) -> None:
        for token in ("wrong", "", TOKEN):
            with self.assertRaises(ServerError) as caught:
                geoprox.Client("127.0.0.1", self.port(), timeout=10, token=token)
            self.assertEqual(caught.exception.reason, Reason.UNAUTHORIZED, token)
        client = geoprox.Client("127.0.0.1", self.port(), timeout=10, token="wrong", connect=False)
        with client:
            with self.assertRaises(ServerError) as caught:
                client.distance("spot", "v:0", "v:1")
            self.assertEqual(caught.exception.reason, Reason.UNAUTHORIZED)
            self.assertFalse(client.connected)

    def test_token_from_the_environment(self) -> None:
        os.environ["GEOPROX_TOKEN"] = QUERY_TOKEN
        try:
            with geoprox.Client("127.0.0.1", self.port(), timeout=10) as client:
                self.assertEqual(client.mesh_list()["meshes"][0]["id"], "spot")
            # An explicit token wins over the environment.
            with self.assertRaises(ServerError):
                geoprox.Client("127.0.0.1", self.port(), timeout=10, token="wrong")
        finally:
            del os.environ["GEOPROX_TOKEN"]

    def test_open_server_accepts_any_token(self) -> None:
        with daemon().client(timeout=10, token="anything") as client:
            self.assertEqual(client.distance("spot", "v:0", "v:1")["target"], {"vertex": 1})

    def test_token_is_not_in_the_log(self) -> None:
        with self.assertRaises(ServerError):
            geoprox.Client("127.0.0.1", self.port(), timeout=10, token="guess-77e1")
        assert self.secured is not None
        log = self.secured.output()
        self.assertIn("server.auth refused", log)
        for secret in (QUERY_TOKEN, "guess-77e1"):
            self.assertNotIn(secret, log)


if __name__ == "__main__":
    unittest.main()
