"""Tests of the HTTP transport of the geoprox Python client (geoprox.HttpClient).

test_client.py runs every API test over both transports against one daemon; this module has
what only HTTP has: the query token as a bearer token (401 and 403 surfaced as Unauthorized),
one keep-alive connection for everything, the daemon restarting under a client, binary arrays
from the resource endpoints. Its daemons are geoproxd subprocesses (GEOPROXD, as in
test_client.py) on a temporary copy of spot.obj. A tiny fake HTTP server stands in where the
daemon cannot be made to misbehave on cue: a keep-alive connection closed as a request arrives,
error statuses without a JSON body, a reply that never comes, batch arrays refused.
"""

from __future__ import annotations

import array
import http.client
import json
import math
import os
import random
import shutil
import socket
import tempfile
import threading
import time
import unittest
from pathlib import Path
from typing import Any, Callable, Optional

import geoprox
from geoprox import GeoproxConnectionError, GeoproxTimeoutError, Reason, ServerError
from test_client import QUERY_TOKEN, SPOT_FACES, SPOT_OBJ, SPOT_VERTICES, TOKEN, Daemon

ROOT: Optional[tempfile.TemporaryDirectory] = None


def root() -> Path:
    assert ROOT is not None
    return Path(ROOT.name)


def setUpModule() -> None:
    global ROOT
    binary = os.environ.get("GEOPROXD")
    if not binary or not os.access(binary, os.X_OK):
        raise RuntimeError("GEOPROXD must name the geoproxd binary (ctest sets it)")
    os.environ.pop("GEOPROX_TOKEN", None)
    ROOT = tempfile.TemporaryDirectory(prefix="geoprox-http-test-")
    (root() / "data" / "meshes").mkdir(parents=True)
    (root() / "graphs").mkdir()
    shutil.copy(SPOT_OBJ, root() / "data" / "meshes" / "spot.obj")


def tearDownModule() -> None:
    if ROOT is not None:
        ROOT.cleanup()


def start(name: str, **config: Any) -> Daemon:
    """A daemon on the module's data (the first one builds spot's graph, the others load it),
    ready to serve spot."""
    daemon = Daemon(os.environ["GEOPROXD"], root(), name, **config)
    try:
        with daemon.client("tcp", token=config.get("query_token"), timeout=30) as client:
            client.wait_ready("spot", timeout=300)
    except BaseException:
        daemon.stop()
        raise
    return daemon


def raw_get(port: int, path: str, headers: Optional[dict[str, str]] = None) -> tuple[int, Any, str]:
    """GET on a fresh connection, with the standard library alone: (status, headers, body)."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    try:
        conn.request("GET", path, headers=headers or {})
        response = conn.getresponse()
        return response.status, response.headers, response.read().decode()
    finally:
        conn.close()


class LiveHttpTest(unittest.TestCase):
    """One open daemon (an admin token, no query token) for the class."""

    daemon: Optional[Daemon] = None

    @classmethod
    def setUpClass(cls) -> None:
        cls.daemon = start("open")

    @classmethod
    def tearDownClass(cls) -> None:
        if cls.daemon is not None:
            cls.daemon.stop()

    def client(self, **options: Any) -> geoprox.Client:
        assert self.daemon is not None
        return self.daemon.client("http", timeout=60, **options)

    def test_client_and_connect_make_http_clients(self) -> None:
        assert self.daemon is not None
        for client in (
            geoprox.Client(self.daemon.url),
            geoprox.connect(self.daemon.url + "/"),
            geoprox.Client("http://127.0.0.1", self.daemon.http_port),  # port apart
        ):
            with client:
                self.assertIsInstance(client, geoprox.HttpClient)
                self.assertIsInstance(client, geoprox.Client)
                self.assertTrue(client.connected)
                self.assertEqual(client.port, self.daemon.http_port)
                self.assertEqual(client.mesh_info("spot")["vertices"], SPOT_VERTICES)
        os.environ["GEOPROX_HOST"] = self.daemon.url
        try:
            with geoprox.Client() as client:
                self.assertIsInstance(client, geoprox.HttpClient)
                self.assertTrue(client.health()["ready"])
        finally:
            del os.environ["GEOPROX_HOST"]
        with self.assertRaises(ValueError):
            geoprox.Client("https://127.0.0.1:7880")
        with self.assertRaises(ValueError):
            geoprox.Client("http://127.0.0.1:7880/?x=1")

    def test_one_keep_alive_connection_for_everything(self) -> None:
        r = geoprox.request
        with self.client(admin_token=TOKEN) as client:
            sock = client.socket
            assert sock is not None
            local = sock.getsockname()
            reference = client.distance("spot", "v:0", "v:700")["distance"]
            for i in range(10):
                self.assertEqual(client.distance("spot", "v:0", "v:700")["distance"], reference)
                self.assertEqual(client.field("spot", f"v:{i}")["reached"], SPOT_VERTICES)
                matrix = client.matrix("spot", ["v:0"], ["v:700", f"v:{i}"])
                self.assertEqual(matrix["distances"][0][0], reference)
                self.assertEqual(client.batch([r.distance("spot", "v:0", "v:700")])[0]["distance"],
                                 reference)
                with client.pipeline() as pipe:
                    pending = [pipe.distance("spot", "v:0", f"v:{j}") for j in range(700, 705)]
                self.assertEqual(pending[0].result()["distance"], reference)
                with self.assertRaises(ServerError):  # an error reply keeps the connection
                    client.mesh_info("nope")
                self.assertEqual(client.admin_reload("spot")["meshes"][0]["mesh"], "spot")
            self.assertIs(client.socket, sock)
            self.assertEqual(sock.getsockname(), local)

    def test_binary_arrays(self) -> None:
        with self.client(use_numpy=False) as client:
            sources = ["v:0", "v:1500"]
            as_json = client.field("spot", sources, cutoff=0.3)
            distances = client.array("spot", "field", {"sources": sources, "cutoff": 0.3})
            self.assertEqual((distances.shape, distances.dtype), ((SPOT_VERTICES,), "float64"))
            self.assertIsInstance(distances.values, array.array)
            self.assertEqual(distances.mesh_version, as_json["mesh_version"])
            for d_json, d_bin in zip(as_json["distances"], distances.values):
                if d_json is None:
                    self.assertTrue(math.isnan(d_bin))
                else:
                    self.assertEqual(d_bin, d_json)  # float64: every bit
            nearest = client.array("spot", "field", {"sources": sources, "cutoff": 0.3},
                                   array="nearest_source")
            self.assertEqual(nearest.dtype, "uint32")
            self.assertEqual(
                list(nearest.values),
                [0xFFFFFFFF if n is None else n for n in as_json["nearest_source"]],
            )
            as_f32 = client.field("spot", "v:0", encoding="f32le-base64")["distances"]
            f32 = client.array("spot", "field", {"source": geoprox.vertex(0)}, dtype="float32")
            self.assertEqual(f32.dtype, "float32")
            self.assertEqual(list(f32.values), list(as_f32))

            targets = ["v:2", "f:100:0.2:0.3:0.5", geoprox.position(0.37, -0.29, 0.19)]
            matrix = client.array("spot", "matrix", {"sources": sources, "targets": targets})
            self.assertEqual(matrix.shape, (2, 3))
            rows = client.matrix("spot", sources, targets)["distances"]
            self.assertEqual(list(matrix.values), rows[0] + rows[1])

            if geoprox.HAVE_NUMPY:
                with self.client() as with_numpy:
                    shaped = with_numpy.array("spot", "matrix",
                                              {"sources": sources, "targets": targets})
                self.assertEqual(shaped.values.shape, (2, 3))
                self.assertEqual(shaped.values.tolist(), rows)

            positions = client.array("spot", "geometry")
            self.assertEqual((positions.shape, positions.dtype), ((SPOT_VERTICES, 3), "float64"))
            triangles = client.array("spot", "geometry", array="triangles")
            self.assertEqual((triangles.shape, triangles.dtype), ((SPOT_FACES, 3), "uint32"))
            self.assertEqual(max(triangles.values), SPOT_VERTICES - 1)
            # The path's end is vertex 9: its position is row 9 of the geometry.
            end = client.path("spot", "v:0", "v:9")["points"][-1]["position"]
            for a, b in zip(end, positions.values[27:30]):
                self.assertAlmostEqual(a, b, places=9)

            with self.assertRaises(ServerError) as caught:
                client.array("nope", "field", {"source": "v:0"})
            self.assertEqual(caught.exception.reason, Reason.UNKNOWN_MESH)
            self.assertEqual(caught.exception.http_status, 404)
            with self.assertRaises(ServerError) as caught:
                client.array("spot", "field", {"source": "v:99999"})
            self.assertEqual(caught.exception.reason, Reason.VERTEX_OUT_OF_RANGE)
            self.assertEqual(caught.exception.http_status, 400)

    def test_status_of_error_replies(self) -> None:
        with self.client(admin_token=TOKEN) as client:
            cases: list[tuple[Callable[[], Any], str, int]] = [
                (lambda: client.distance("nope", "v:0", "v:1"), Reason.UNKNOWN_MESH, 404),
                (lambda: client.call("geodesic.distances"), Reason.UNKNOWN_METHOD, 404),
                (lambda: client.distance("spot", "v:0", "v:99999"), Reason.VERTEX_OUT_OF_RANGE,
                 400),
                (lambda: client.admin_register("spot", "meshes/spot.obj"), Reason.MESH_EXISTS,
                 409),
            ]
            for call, reason, status in cases:
                with self.subTest(reason=reason), self.assertRaises(ServerError) as caught:
                    call()
                self.assertEqual(caught.exception.reason, reason)
                self.assertEqual(caught.exception.http_status, status)
            # A wrong admin token (in params, no bearer token on an open server): 401 or 403.
            with self.assertRaises(ServerError) as caught:
                client.admin_reload(token="wrong")
            self.assertEqual(caught.exception.reason, Reason.UNAUTHORIZED)
            self.assertIn(caught.exception.http_status, (401, 403))
            # In a pipeline (a batch array, status 200) the errors have no status of their own.
            pipe = client.pipeline()
            bad, good = pipe.mesh_info("nope"), pipe.health()
            pipe.execute()
            self.assertEqual(bad.exception().reason, Reason.UNKNOWN_MESH)
            self.assertIsNone(bad.exception().http_status)
            self.assertTrue(good.result()["ready"])


class BearerTokenTest(unittest.TestCase):
    """A daemon with a query token: every HTTP request but /healthz and /readyz needs it."""

    daemon: Optional[Daemon] = None

    @classmethod
    def setUpClass(cls) -> None:
        cls.daemon = start("secured", query_token=QUERY_TOKEN)

    @classmethod
    def tearDownClass(cls) -> None:
        if cls.daemon is not None:
            cls.daemon.stop()

    def url(self) -> str:
        assert self.daemon is not None
        return self.daemon.url

    def test_missing_token_is_401_unauthorized(self) -> None:
        with geoprox.Client(self.url(), timeout=10) as client:
            for call in (
                lambda: client.distance("spot", "v:0", "v:1"),
                lambda: client.mesh_list(),
                lambda: client.health(),  # unlike TCP: only /healthz and /readyz are open
            ):
                with self.assertRaises(ServerError) as caught:
                    call()
                self.assertEqual(caught.exception.reason, Reason.UNAUTHORIZED)
                self.assertEqual(caught.exception.code, -32040)
                self.assertEqual(caught.exception.http_status, 401)
                self.assertFalse(caught.exception.retryable)
            with client.pipeline() as pipe:
                pending = [pipe.health(), pipe.mesh_info("spot")]
            for p in pending:
                self.assertEqual(p.exception().reason, Reason.UNAUTHORIZED)
        assert self.daemon is not None
        status, headers, _ = raw_get(self.daemon.http_port, "/v1/meshes")
        self.assertEqual(status, 401)
        self.assertTrue(headers.get("WWW-Authenticate", "").startswith("Bearer"))
        status, _, body = raw_get(self.daemon.http_port, "/healthz")
        self.assertEqual((status, body.strip()), (200, "ok"))
        status, _, body = raw_get(self.daemon.http_port, "/readyz")
        self.assertEqual((status, body.strip()), (200, "ready"))

    def test_wrong_token_is_403_unauthorized(self) -> None:
        for token in ("wrong", TOKEN):
            with geoprox.Client(self.url(), timeout=10, token=token) as client:
                self.assertTrue(client.connected)  # no handshake: refused at the first request
                with self.assertRaises(ServerError) as caught:
                    client.distance("spot", "v:0", "v:1")
                self.assertEqual(caught.exception.reason, Reason.UNAUTHORIZED)
                self.assertEqual(caught.exception.http_status, 403)

    def test_token_opens_queries_pipelines_and_batches(self) -> None:
        assert self.daemon is not None
        with self.daemon.client("tcp", token=QUERY_TOKEN, timeout=30) as reference:
            expected = reference.distance("spot", "v:0", "f:100:0.2:0.3:0.5")["distance"]
        with geoprox.Client(self.url(), timeout=30, token=QUERY_TOKEN) as client:
            self.assertTrue(client.health()["auth_required"])
            self.assertEqual(
                client.distance("spot", "v:0", "f:100:0.2:0.3:0.5")["distance"], expected
            )
            with client.pipeline() as pipe:
                pending = [pipe.distance("spot", "v:0", f"v:{i}") for i in range(1, 20)]
            self.assertTrue(all(p.result()["distance"] > 0 for p in pending))
            (first,) = client.batch([geoprox.request.distance("spot", "v:0", "f:100:0.2:0.3:0.5")])
            self.assertEqual(first["distance"], expected)
            self.assertEqual(client.array("spot", "field", {"source": "v:0"}).shape,
                             (SPOT_VERTICES,))
        os.environ["GEOPROX_TOKEN"] = QUERY_TOKEN
        try:
            with geoprox.Client(self.url(), timeout=10) as client:
                self.assertEqual(client.mesh_list()["meshes"][0]["id"], "spot")
        finally:
            del os.environ["GEOPROX_TOKEN"]


class RestartTest(unittest.TestCase):
    def test_daemon_restarts_under_a_client(self) -> None:
        first = start("restart-1")
        port = first.http_port
        second: Optional[Daemon] = None
        third: Optional[Daemon] = None
        client: Optional[geoprox.Client] = None
        try:
            client = first.client("http", timeout=30)
            expected = client.distance("spot", "v:0", "v:1234")["distance"]
            old_socket = client.socket
            self.assertEqual(first.stop(), 0)
            # Down: the client's connection is gone and no other can be opened.
            with self.assertRaises(GeoproxConnectionError) as caught:
                client.health()
            self.assertEqual(caught.exception.reason, Reason.CONNECTION_FAILED)
            self.assertFalse(client.connected)
            # Up again on the same port: the same client carries on.
            second = Daemon(os.environ["GEOPROXD"], root(), "restart-2", http_port=port)
            client.wait_ready("spot", timeout=120)
            self.assertEqual(client.distance("spot", "v:0", "v:1234")["distance"], expected)
            self.assertIsNot(client.socket, old_socket)
            # Restarted while the client was idle on a keep-alive connection: no error at all.
            old_socket = client.socket
            self.assertEqual(second.stop(), 0)
            third = start("restart-3", http_port=port)
            self.assertEqual(client.distance("spot", "v:0", "v:1234")["distance"], expected)
            self.assertIsNot(client.socket, old_socket)
            # Killed: refused.
            third.process.kill()
            third.process.wait()
            with self.assertRaises(GeoproxConnectionError):
                client.health()
        finally:
            if client is not None:
                client.close()
            for daemon in (first, second, third):
                if daemon is not None:
                    daemon.stop()


    def test_daemon_closes_idle_keep_alive_connection(self) -> None:
        daemon = start("idle", limits={"read_timeout_ms": 200})
        try:
            with daemon.client("http", timeout=30) as client:
                expected = client.distance("spot", "v:0", "v:42")["distance"]
                first = client.socket
                time.sleep(1.0)  # the daemon closes the idle connection after 0.2 s
                self.assertEqual(client.distance("spot", "v:0", "v:42")["distance"], expected)
                self.assertIsNot(client.socket, first)  # a new one, transparently
                second = client.socket
                with client.pipeline() as pipe:  # a pipeline too, on a connection kept alive
                    pending = [pipe.distance("spot", "v:0", f"v:{i}") for i in range(40, 45)]
                self.assertEqual(pending[2].result()["distance"], expected)
                self.assertIs(client.socket, second)
        finally:
            self.assertEqual(daemon.stop(), 0)


class FakeHttpServer:
    """A one-connection-at-a-time HTTP server on 127.0.0.1 whose behaviour per connection is
    `handle(connection, read_request)`; `read_request()` reads one request (method, path,
    headers, parsed JSON body) or returns None at the end of the connection. Every request read
    is kept in `requests`."""

    def __init__(self, handle: Callable[[socket.socket, Callable[[], Any]], None]) -> None:
        self._handle = handle
        self._listener = socket.create_server(("127.0.0.1", 0))
        self.port = self._listener.getsockname()[1]
        self.url = f"http://127.0.0.1:{self.port}"
        self.requests: list[Any] = []
        self.connections = 0
        self._thread = threading.Thread(target=self._serve, daemon=True)

    def _serve(self) -> None:
        while True:
            try:
                connection, _ = self._listener.accept()
            except OSError:
                return
            self.connections += 1
            with connection:
                reader = connection.makefile("rb")

                def read_request() -> Any:
                    line = reader.readline()
                    if not line:
                        return None
                    method, path, _ = line.decode().split(" ", 2)
                    headers = {}
                    while (h := reader.readline().decode().strip()) != "":
                        name, _, value = h.partition(":")
                        headers[name.strip().lower()] = value.strip()
                    body = reader.read(int(headers.get("content-length", 0)))
                    request = (method, path, headers, json.loads(body) if body else None)
                    self.requests.append(request)
                    return request

                try:
                    self._handle(connection, read_request)
                except (OSError, ValueError):
                    pass
                finally:
                    reader.close()

    def __enter__(self) -> "FakeHttpServer":
        self._thread.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        try:
            self._listener.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self._listener.close()
        self._thread.join(timeout=5)


def respond(connection: socket.socket, status: int, body: Any, **headers: str) -> None:
    """Writes one HTTP/1.1 response (keep-alive); a non-str, non-bytes body is sent as JSON."""
    if isinstance(body, str):
        data, kind = body.encode(), "text/plain"
    elif isinstance(body, bytes):
        data, kind = body, "application/octet-stream"
    else:
        data, kind = json.dumps(body).encode(), "application/json"
    lines = [f"HTTP/1.1 {status} {http.client.responses.get(status, 'Status')}",
             f"Content-Type: {kind}", f"Content-Length: {len(data)}"]
    lines += [f"{k.replace('_', '-')}: {v}" for k, v in headers.items()]
    connection.sendall(("\r\n".join(lines) + "\r\n\r\n").encode() + data)


def answer(request: Any) -> Any:
    """The JSON-RPC response (or array of them) echoing each request's params."""
    body = request[3]
    if isinstance(body, list):
        return [answer((None, None, None, b)) for b in body]
    return {"jsonrpc": "2.0", "id": body["id"], "result": {"echo": body.get("params", {})}}


class FakeServerTest(unittest.TestCase):
    def test_stale_keep_alive_is_replaced_for_queries_not_admin(self) -> None:
        # Each connection answers its first request, then reads the next and hangs up without a
        # word, as a server whose idle timeout fires just as the request arrives.
        def handle(connection: socket.socket, read_request: Callable[[], Any]) -> None:
            respond(connection, 200, answer(read_request()))
            read_request()

        with FakeHttpServer(handle) as server:
            with geoprox.Client(server.url, timeout=10) as client:
                self.assertEqual(client.call("server.health", {"n": 1}), {"echo": {"n": 1}})
                self.assertEqual(client.call("server.health", {"n": 2}), {"echo": {"n": 2}})
                with self.assertRaises(GeoproxConnectionError) as caught:
                    client.admin_reload(token="t")
                self.assertEqual(caught.exception.reason, Reason.CONNECTION_CLOSED)
            methods = [r[3]["method"] for r in server.requests]
            # The second health twice (the first time into the closed connection), the admin
            # call once: it is not repeated, since it may have been carried out.
            self.assertEqual(methods, ["server.health"] * 3 + ["admin.reload"])
            self.assertEqual(server.connections, 2)

    def test_a_new_connection_closed_mid_request_is_not_retried(self) -> None:
        def handle(connection: socket.socket, read_request: Callable[[], Any]) -> None:
            read_request()

        with FakeHttpServer(handle) as server, geoprox.Client(server.url, timeout=10) as client:
            with self.assertRaises(GeoproxConnectionError) as caught:
                client.health()
            self.assertIsInstance(caught.exception, ConnectionError)
            self.assertEqual(caught.exception.reason, Reason.CONNECTION_CLOSED)
            self.assertFalse(client.connected)
            self.assertEqual(len(server.requests), 1)

    def test_errors_from_status_when_the_body_has_none(self) -> None:
        replies = [
            (502, "<html>Bad Gateway</html>", {}),
            (503, "draining", {"Retry_After": "2"}),
            (401, "no token", {"WWW_Authenticate": "Bearer"}),
            (413, "", {"Connection": "close"}),
            (404, {"jsonrpc": "2.0", "id": None, "error": {
                "code": -32001, "message": "no mesh", "data": {"reason": "UnknownMesh"}}}, {}),
            (429, {"jsonrpc": "2.0", "id": None, "error": {
                "code": -32030, "message": "queue full",
                "data": {"reason": "Overloaded", "retryable": True}}}, {"Retry_After": "1"}),
        ]

        def handle(connection: socket.socket, read_request: Callable[[], Any]) -> None:
            while read_request() is not None:
                status, body, headers = replies.pop(0)
                respond(connection, status, body, **headers)
                if headers.get("Connection") == "close":
                    return

        expected = [
            (Reason.INTERNAL, -32603, True, None, 502),
            (Reason.SHUTTING_DOWN, -32032, True, 2000, 503),
            (Reason.UNAUTHORIZED, -32040, False, None, 401),
            (Reason.TOO_LARGE, -32020, False, None, 413),
            (Reason.UNKNOWN_MESH, -32001, False, None, 404),  # the body's reason, not NotFound
            (Reason.OVERLOADED, -32030, True, 1000, 429),
        ]
        with FakeHttpServer(handle) as server, geoprox.Client(server.url, timeout=10) as client:
            errors = []
            for reason, code, retryable, retry_after_ms, status in expected:
                with self.subTest(status=status), self.assertRaises(ServerError) as caught:
                    client.health()
                error = caught.exception
                errors.append(error)
                self.assertEqual(
                    (error.reason, error.code, error.retryable, error.retry_after_ms,
                     error.http_status),
                    (reason, code, retryable, retry_after_ms, status),
                )
            self.assertEqual(errors[0].message, "HTTP 502 Bad Gateway: <html>Bad Gateway</html>")
            self.assertEqual(errors[4].message, "no mesh")
            self.assertEqual(server.connections, 2)  # "Connection: close" after the 413

    def test_client_timeout_drops_the_connection(self) -> None:
        def handle(connection: socket.socket, read_request: Callable[[], Any]) -> None:
            request = read_request()
            if request[3]["method"] == "slow":
                time.sleep(2.0)
                return
            respond(connection, 200, answer(request))

        with FakeHttpServer(handle) as server, geoprox.Client(server.url, timeout=0.2) as client:
            started = time.monotonic()
            with self.assertRaises(GeoproxTimeoutError) as caught:
                client.call("slow")
            self.assertLess(time.monotonic() - started, 1.5)
            self.assertIsInstance(caught.exception, TimeoutError)
            self.assertFalse(client.connected)  # a late reply must not answer the next request
            client.timeout = 10
            self.assertEqual(client.call("fast", {"a": 1}), {"echo": {"a": 1}})

    def test_pipelines_are_batch_arrays_within_the_limits(self) -> None:
        def handle(connection: socket.socket, read_request: Callable[[], Any]) -> None:
            while (request := read_request()) is not None:
                reply = answer(request)
                if isinstance(reply, list):
                    random.Random(len(reply)).shuffle(reply)  # any order: matched by id
                respond(connection, 200, reply)

        with FakeHttpServer(handle) as server:
            with geoprox.Client(server.url, timeout=10, max_batch_requests=3,
                                max_line_bytes=2000) as client:
                client.max_points_per_request = 5
                with client.pipeline() as pipe:
                    small = [pipe.call("m", {"i": i}) for i in range(7)]
                    big = pipe.call("m", {"pad": "x" * 3000})  # alone: over max_line_bytes
                    last = pipe.call("m", {"i": 7})
                    distances = [pipe.distance("s", "v:0", "v:1") for _ in range(2)]
                    matrix = pipe.matrix("s", ["v:0"], ["v:1", "v:2"])  # alone: a large reply
                    many = pipe.call("m", {"sources": ["v:0"] * 4})
                    distances.append(pipe.distance("s", "v:0", "v:1"))  # 4 + 2 points > 5
                    after = pipe.health()
            self.assertEqual([p.result()["echo"]["i"] for p in small], list(range(7)))
            self.assertEqual(len(big.result()["echo"]["pad"]), 3000)
            self.assertEqual(last.result(), {"echo": {"i": 7}})
            self.assertEqual(distances[1].result()["echo"]["target"], "v:1")
            self.assertEqual(matrix.result()["echo"]["targets"], ["v:1", "v:2"])
            self.assertEqual(many.result()["echo"]["sources"], ["v:0"] * 4)
            self.assertEqual(after.result(), {"echo": {}})
            bodies = [r[3] for r in server.requests]
            shapes = [len(b) if isinstance(b, list) else b["method"] for b in bodies]
            self.assertEqual(shapes, [3, 3, "m", "m", 3, "geodesic.matrix", "m", 2])
            self.assertTrue(all(r[:2] == ("POST", "/v1/rpc") for r in server.requests))
            self.assertTrue(all(r[2]["content-type"] == "application/json"
                                for r in server.requests))
            self.assertEqual(server.connections, 1)

    def test_batch_array_refused_whole(self) -> None:
        # Overloaded: every element gets the error, and the array the status and Retry-After.
        def handle(connection: socket.socket, read_request: Callable[[], Any]) -> None:
            while (request := read_request()) is not None:
                error = {"code": -32030, "message": "compute queue full",
                         "data": {"reason": "Overloaded", "retryable": True}}
                respond(connection, 429,
                        [{"jsonrpc": "2.0", "id": b["id"], "error": error} for b in request[3]],
                        Retry_After="1")

        with FakeHttpServer(handle) as server, geoprox.Client(server.url, timeout=10) as client:
            outcomes = client.call_many([("a", {}), ("b", {})], return_exceptions=True)
        for error in outcomes:
            self.assertIsInstance(error, ServerError)
            self.assertEqual((error.reason, error.retryable, error.retry_after_ms,
                              error.http_status), (Reason.OVERLOADED, True, 1000, 429))

    def test_server_without_batch_arrays_gets_one_request_at_a_time(self) -> None:
        refusal = {"jsonrpc": "2.0", "id": None, "error": {
            "code": -32600, "message": "batch arrays are not supported",
            "data": {"reason": "InvalidRequest", "retryable": False}}}

        def handle(connection: socket.socket, read_request: Callable[[], Any]) -> None:
            while (request := read_request()) is not None:
                if isinstance(request[3], list):
                    respond(connection, 400, refusal)
                else:
                    respond(connection, 200, answer(request))

        with FakeHttpServer(handle) as server, geoprox.Client(server.url, timeout=10) as client:
            self.assertEqual(client.call_many([("m", {"i": i}) for i in range(4)]),
                             [{"echo": {"i": i}} for i in range(4)])
            self.assertEqual(client.call_many([("m", {"i": i}) for i in range(2)]),
                             [{"echo": {"i": i}} for i in range(2)])
            shapes = [len(r[3]) if isinstance(r[3], list) else "single" for r in server.requests]
            self.assertEqual(shapes, [4] + ["single"] * 6)  # asked once, then never again

    def test_bearer_token_header(self) -> None:
        def handle(connection: socket.socket, read_request: Callable[[], Any]) -> None:
            while (request := read_request()) is not None:
                respond(connection, 200, answer(request))

        with FakeHttpServer(handle) as server:
            with geoprox.Client(server.url, token="s3cret", timeout=10) as client:
                client.health()
                client.call_many([("a", {}), ("b", {})])
            with geoprox.Client(server.url, timeout=10) as client:
                client.health()
        auth = [r[2].get("authorization") for r in server.requests]
        self.assertEqual(auth, ["Bearer s3cret", "Bearer s3cret", None])
        self.assertEqual([r[3]["method"] for r in server.requests if isinstance(r[3], dict)],
                         ["server.health", "server.health"])  # no server.auth over HTTP


if __name__ == "__main__":
    unittest.main()
