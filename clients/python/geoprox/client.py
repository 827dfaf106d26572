"""The geoprox client: newline-delimited JSON-RPC 2.0 over TCP (docs/protocol.md), or over
HTTP with ``Client("http://host:7880")`` (:mod:`geoprox.httpclient`).

Three ways to send the same requests, with the same method signatures:

- :class:`Client` sends one request and waits for its reply (``client.distance(...)``);
- :meth:`Client.pipeline` queues requests, sends them all before reading, and matches the
  replies by id, whatever their order (``with client.pipeline() as p: a = p.distance(...)``);
- :data:`request` builds :class:`Request` values for :meth:`Client.batch` (the protocol's
  ``batch`` method: one line, one answer) and :meth:`Client.call_many`.

Results are the ``result`` objects of docs/protocol.md as dicts, except ``geodesic.field``
and ``geodesic.matrix`` results in a base64 encoding, whose arrays are decoded (see
:mod:`geoprox.encoding`), and results asked for with ``as_array=True`` (or
``Client(..., arrays=True)``), whose distances, fields and paths are numpy arrays (see
:mod:`geoprox.arrays`). Failures raise :class:`~geoprox.errors.GeoproxError` subclasses.
"""

from __future__ import annotations

import json
import os
import selectors
import socket
import threading
import time
from dataclasses import dataclass, field as dataclass_field
from typing import (
    Any,
    Generic,
    Iterable,
    Mapping,
    Optional,
    Sequence,
    TypeVar,
    Union,
    cast,
)

from .arrays import PointSet, field_arrays, matrix_arrays, path_arrays, require_numpy
from .encoding import decode_field_result, decode_matrix_result
from .errors import (
    GeoproxConnectionError,
    GeoproxError,
    GeoproxProtocolError,
    GeoproxTimeoutError,
    Reason,
    ServerError,
    error_from_reply,
)
from .points import Point, as_point

__all__ = [
    "Client",
    "Pipeline",
    "Pending",
    "Request",
    "RequestBuilder",
    "request",
    "connect",
    "DEFAULT_HOST",
    "DEFAULT_PORT",
]

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 7878

#: A result object of docs/protocol.md.
Result = dict[str, Any]

T = TypeVar("T")
#: What :meth:`Client.batch`, :meth:`Client.call_many` and :meth:`Pipeline.add` accept: a
#: :class:`Request`, a ``(method, params)`` tuple or a ``{"method", "params"}`` mapping.
RequestLike = Union["Request", tuple[str, Mapping[str, Any]], Mapping[str, Any]]

_ADMIN_PREFIX = "admin."
_RECV_BYTES = 256 * 1024
_SEND_BYTES = 256 * 1024


@dataclass(frozen=True)
class Request:
    """One request: a method name and its params (``timeout_ms`` included, when given).

    ``arrays``: its result is decoded into numpy arrays (``as_array=True``); for a ``batch``,
    ``entry_arrays`` says it of each entry. Neither goes on the wire."""

    method: str
    params: dict[str, Any] = dataclass_field(default_factory=dict)
    arrays: bool = False
    entry_arrays: tuple[bool, ...] = ()

    def entry(self) -> dict[str, Any]:
        """The ``{"method", "params"}`` object of a ``batch`` entry."""
        return {"method": self.method, "params": self.params}


def _to_request(item: RequestLike) -> Request:
    if isinstance(item, Request):
        return item
    if isinstance(item, tuple) and len(item) == 2:
        return Request(item[0], dict(item[1] or {}))
    if isinstance(item, Mapping) and "method" in item:
        return Request(item["method"], dict(item.get("params") or {}))
    raise TypeError(f"not a request: {item!r} (use geoprox.request.distance(...) or similar)")


class _Methods(Generic[T]):
    """Every method of docs/protocol.md, each turned into a :class:`Request` and handed to
    :meth:`_submit`, whose return value it returns."""

    _admin_token: Optional[str] = None
    #: Whether results of field, matrix and path are numpy arrays when a call does not say.
    _arrays: bool = False

    def _submit(self, req: Request) -> T:
        raise NotImplementedError

    def _want_arrays(self, as_array: Optional[bool]) -> bool:
        wanted = self._arrays if as_array is None else bool(as_array)
        if wanted:
            require_numpy("as_array")
        return wanted

    def _params(self, timeout_ms: Optional[int], **params: Any) -> dict[str, Any]:
        out = {k: v for k, v in params.items() if v is not None}
        if timeout_ms is not None:
            out["timeout_ms"] = timeout_ms
        return out

    def call(self, method: str, params: Optional[Mapping[str, Any]] = None) -> T:
        """Any method by name, with its params as given."""
        return self._submit(Request(method, dict(params or {})))

    # ---- queries ----

    def distance(
        self,
        mesh: str,
        source: Point,
        target: Point,
        *,
        exact: Optional[bool] = None,
        timeout_ms: Optional[int] = None,
    ) -> T:
        """``geodesic.distance``: result ``distance``, ``exact``, ``source``, ``target``.

        ``exact=True`` asks for an exact solve instead of the graph's approximation."""
        return self._submit(
            Request(
                "geodesic.distance",
                self._params(
                    timeout_ms,
                    mesh=mesh,
                    source=as_point(source),
                    target=as_point(target),
                    exact=exact,
                ),
            )
        )

    def path(
        self,
        mesh: str,
        source: Point,
        target: Point,
        *,
        as_array: Optional[bool] = None,
        timeout_ms: Optional[int] = None,
    ) -> T:
        """``geodesic.path``: result ``distance`` and ``points`` (each ``face``, ``bary``,
        ``position``). With ``as_array``, ``points`` is replaced by numpy arrays ``faces`` (n),
        ``bary`` (n x 3) and ``xyz`` (n x 3)."""
        return self._submit(
            Request(
                "geodesic.path",
                self._params(
                    timeout_ms, mesh=mesh, source=as_point(source), target=as_point(target)
                ),
                arrays=self._want_arrays(as_array),
            )
        )

    def field(
        self,
        mesh: str,
        source: Union[Point, Sequence[Point], None] = None,
        *,
        sources: Optional[Sequence[Point]] = None,
        cutoff: Optional[float] = None,
        encoding: Optional[str] = None,
        as_array: Optional[bool] = None,
        timeout_ms: Optional[int] = None,
    ) -> T:
        """``geodesic.field``: the distance of every vertex from ``source`` or from the nearest
        of ``sources`` (a list or a :class:`~geoprox.arrays.PointSet` given as ``source``
        counts as ``sources``).

        ``encoding`` is ``"json"`` (the server's default: ``distances`` is a list with None
        where not reached), ``"f32le-base64"`` (decoded into a float32 array with ``inf``
        where not reached; ``nearest_source`` into a uint32 array with ``0xFFFFFFFF``) or
        ``"f64le-base64"`` (a float64 array, ``inf`` where not reached). ``as_array``:
        ``distances`` is a float64 numpy array with NaN where not reached (sent exactly),
        ``nearest_source`` a uint32 one with ``0xFFFFFFFF``."""
        arrays = self._want_arrays(as_array)
        if arrays:
            if encoding not in (None, "f64le-base64"):
                raise ValueError(f"as_array takes the field as float64, not {encoding!r}")
            encoding = "f64le-base64"
        single: Optional[Point] = None
        if isinstance(source, PointSet) and len(source) > 1:
            if sources is not None:
                raise TypeError("give source or sources, not both")
            sources = source
        elif isinstance(source, (list, tuple)):
            if sources is not None:
                raise TypeError("give source or sources, not both")
            sources = source
        elif source is not None:
            single = cast(Point, source)
        return self._submit(
            Request(
                "geodesic.field",
                self._params(
                    timeout_ms,
                    mesh=mesh,
                    source=None if single is None else as_point(single),
                    sources=None if sources is None else [as_point(p) for p in sources],
                    cutoff=cutoff,
                    encoding=encoding,
                ),
                arrays=arrays,
            )
        )

    def matrix(
        self,
        mesh: str,
        sources: Sequence[Point],
        targets: Sequence[Point],
        *,
        as_array: Optional[bool] = None,
        timeout_ms: Optional[int] = None,
    ) -> T:
        """``geodesic.matrix``: ``distances[i][j]`` from ``sources[i]`` to ``targets[j]``
        (None where unreachable, counted by ``unreachable``). With ``as_array``,
        ``distances`` is a sources x targets float64 numpy array, NaN where unreachable, sent
        exactly (``"f64le-base64"`` over TCP, raw float64 over HTTP)."""
        arrays = self._want_arrays(as_array)
        return self._submit(
            Request(
                "geodesic.matrix",
                self._params(
                    timeout_ms,
                    mesh=mesh,
                    sources=[as_point(p) for p in sources],
                    targets=[as_point(p) for p in targets],
                    encoding="f64le-base64" if arrays else None,
                ),
                arrays=arrays,
            )
        )

    def batch(
        self,
        requests: Iterable[RequestLike],
        *,
        timeout_ms: Optional[int] = None,
    ) -> T:
        """The ``batch`` method: several requests in one line, answered in one line.

        ``requests`` are :class:`Request` values (``geoprox.request.distance(...)``),
        ``(method, params)`` tuples or ``{"method", "params"}`` dicts. With a :class:`Client`
        the answer is a list in the same order, each item the entry's result or the
        :class:`ServerError` it failed with (entries fail alone; nothing is raised for them)."""
        items = [_to_request(r) for r in requests]
        return self._submit(
            Request(
                "batch",
                self._params(timeout_ms, requests=[r.entry() for r in items]),
                entry_arrays=tuple(r.arrays for r in items),
            )
        )

    # ---- meshes and server ----

    def mesh_list(self, *, timeout_ms: Optional[int] = None) -> T:
        """``mesh.list``: ``meshes``, each with ``id``, ``state`` (ready, building, failed),
        ``progress``, ``phase``, ``error``, sizes and ``mesh_version``."""
        return self._submit(Request("mesh.list", self._params(timeout_ms)))

    def mesh_info(self, mesh: str, *, timeout_ms: Optional[int] = None) -> T:
        """``mesh.info``: one mesh's state, sizes, files and build parameters."""
        return self._submit(Request("mesh.info", self._params(timeout_ms, mesh=mesh)))

    def server_info(self, *, timeout_ms: Optional[int] = None) -> T:
        """``server.info``: protocol and server versions, limits, encodings, methods."""
        return self._submit(Request("server.info", self._params(timeout_ms)))

    def health(self, *, timeout_ms: Optional[int] = None) -> T:
        """``server.health``: ``status`` (ok, starting, draining), ``ready``, counts."""
        return self._submit(Request("server.health", self._params(timeout_ms)))

    def metrics(self, *, timeout_ms: Optional[int] = None) -> T:
        """``server.metrics``: the Prometheus text exposition in ``text``."""
        return self._submit(Request("server.metrics", self._params(timeout_ms)))

    # ---- admin (token: the argument, else the client's admin_token) ----

    def _token(self, token: Optional[str]) -> Optional[str]:
        return token if token is not None else self._admin_token

    def admin_register(
        self,
        mesh: str,
        mesh_file: str,
        *,
        graph_file: Optional[str] = None,
        build: Optional[Mapping[str, Any]] = None,
        repair: bool = False,
        token: Optional[str] = None,
        timeout_ms: Optional[int] = None,
    ) -> T:
        """``admin.register``: registers a mesh (files relative to the server's data
        directory) and starts building or loading its graph; answers its summary at once.
        ``repair=True`` serves the mesh file repaired (ids as ``geoprox repair`` writes)."""
        return self._submit(
            Request(
                "admin.register",
                self._params(
                    timeout_ms,
                    token=self._token(token),
                    mesh=mesh,
                    mesh_file=mesh_file,
                    graph_file=graph_file,
                    build=None if build is None else dict(build),
                    repair=True if repair else None,
                ),
            )
        )

    def admin_rebuild(
        self,
        mesh: str,
        *,
        build: Optional[Mapping[str, Any]] = None,
        token: Optional[str] = None,
        timeout_ms: Optional[int] = None,
    ) -> T:
        """``admin.rebuild``: rebuilds a mesh's graph in the background."""
        return self._submit(
            Request(
                "admin.rebuild",
                self._params(
                    timeout_ms,
                    token=self._token(token),
                    mesh=mesh,
                    build=None if build is None else dict(build),
                ),
            )
        )

    def admin_unregister(
        self, mesh: str, *, token: Optional[str] = None, timeout_ms: Optional[int] = None
    ) -> T:
        """``admin.unregister``: removes a mesh."""
        return self._submit(
            Request(
                "admin.unregister", self._params(timeout_ms, token=self._token(token), mesh=mesh)
            )
        )

    def admin_reload(
        self,
        mesh: Optional[str] = None,
        *,
        token: Optional[str] = None,
        timeout_ms: Optional[int] = None,
    ) -> T:
        """``admin.reload``: reopens graph files (one mesh, or all), like SIGHUP."""
        return self._submit(
            Request("admin.reload", self._params(timeout_ms, token=self._token(token), mesh=mesh))
        )


class RequestBuilder(_Methods[Request]):
    """Builds :class:`Request` values with the client's method signatures, for
    :meth:`Client.batch` and :meth:`Client.call_many`: ``geoprox.request.distance(...)``."""

    def _submit(self, req: Request) -> Request:
        return req


#: The :class:`RequestBuilder`: ``geoprox.request.field("spot", "v:0")`` is a :class:`Request`.
request = RequestBuilder()


class Pending:
    """The reply to come of a pipelined request."""

    def __init__(self, req: Request) -> None:
        self.request = req
        self._done = False
        self._result: Any = None
        self._error: Optional[GeoproxError] = None

    def _resolve(self, result: Any = None, error: Optional[GeoproxError] = None) -> None:
        self._done, self._result, self._error = True, result, error

    def done(self) -> bool:
        """True once the pipeline has run and this request has a result or an error."""
        return self._done

    def exception(self) -> Optional[GeoproxError]:
        """The error this request failed with, or None."""
        self._check_done()
        return self._error

    def result(self) -> Any:
        """The result; raises the request's :class:`GeoproxError` if it failed."""
        self._check_done()
        if self._error is not None:
            raise self._error
        return self._result

    def outcome(self) -> Any:
        """The result, or the error it failed with (returned, not raised)."""
        self._check_done()
        return self._error if self._error is not None else self._result

    def _check_done(self) -> None:
        if not self._done:
            raise RuntimeError(
                "the pipeline has not run yet: leave its with block or call execute()"
            )

    def __repr__(self) -> str:
        state = "pending" if not self._done else ("error" if self._error else "ok")
        return f"<Pending {self.request.method} {state}>"


class Pipeline(_Methods[Pending]):
    """Requests queued to be sent together: every method returns a :class:`Pending`, and
    :meth:`execute` (or leaving the ``with`` block without an exception) sends them all, then
    reads the replies, matched by id in whatever order they come.

    Server errors fail their own request only (``pending.result()`` raises them). A connection
    failure or the pipeline's timeout fails the requests still unanswered and is raised by
    :meth:`execute`; requests answered before it keep their outcome."""

    def __init__(self, client: "Client", timeout: Optional[float]) -> None:
        self._client = client
        self._timeout = timeout
        self._admin_token = client._admin_token
        self._arrays = client._arrays
        self._queue: list[Pending] = []

    def _submit(self, req: Request) -> Pending:
        pending = Pending(req)
        self._queue.append(pending)
        return pending

    def add(self, req: RequestLike) -> Pending:
        """Queues a prepared request."""
        return self._submit(_to_request(req))

    def __len__(self) -> int:
        return len(self._queue)

    def execute(self) -> list[Any]:
        """Sends every queued request, reads every reply; returns the outcomes in queue order
        (result, or the :class:`GeoproxError` of a failed request). The queue is then empty and
        the pipeline may be used again."""
        queue, self._queue = self._queue, []
        if queue:
            self._client._run(queue, self._timeout)
        return [p.outcome() for p in queue]

    def __enter__(self) -> "Pipeline":
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc_type is None:
            self.execute()
        else:
            self._queue.clear()


class Client(_Methods[Any]):
    """A connection to a geoproxd query port.

    Args:
        host, port: the daemon's address; default ``GEOPROX_HOST`` / ``GEOPROX_PORT`` from the
            environment, else 127.0.0.1:7878.
        timeout: seconds to wait for a reply (None: forever). A request with ``timeout_ms``
            waits at least that long plus one second. Past it, :class:`GeoproxTimeoutError`;
            the connection stays usable (a late reply is dropped).
        connect_timeout: seconds to wait for the connection (default: ``timeout``).
        token: the server's query token (default ``GEOPROX_TOKEN`` from the environment):
            every new connection first sends ``server.auth`` with it, and a wrong one raises
            :class:`ServerError` ``Unauthorized``. Servers without a query token accept any.
            Not the admin token.
        admin_token: the token admin methods send when they are not given one.
        retries: how many times :meth:`call` and the query methods retry a request that failed
            with a retryable error (``Overloaded``, ``MeshNotReady``, ``ShuttingDown``, lost
            connection, client timeout...), waiting ``retry_after_ms`` or an exponential
            backoff from ``retry_backoff`` seconds. Admin methods and pipelines never retry.
        use_numpy: decode base64 fields with numpy (None: if importable).
        arrays: field, matrix and path results are numpy arrays unless a call says otherwise
            with ``as_array`` (see :mod:`geoprox.arrays`); needs numpy.
        max_line_bytes: the server's line limit as far as the client knows (``server_info()``
            updates it); an error reply with a null id (a line over the limit) is matched to
            the oldest request longer than this, else to the oldest request.
        connect: open the connection now (else at the first request).

    The connection is opened again by the next request after it broke. :meth:`close` (or
    leaving the ``with`` block) closes it for good. A client may be shared by threads; their
    requests take turns.

    A ``host`` that is an ``http://`` URL (``Client("http://127.0.0.1:7880")``, also from
    ``GEOPROX_HOST``) makes a :class:`~geoprox.httpclient.HttpClient` instead: the same API
    over geoproxd's HTTP port.
    """

    def __new__(cls, host: Optional[str] = None, *args: Any, **options: Any) -> "Client":
        if cls is Client and _is_url(host if host is not None else os.environ.get("GEOPROX_HOST")):
            from .httpclient import HttpClient

            return super().__new__(HttpClient)
        return super().__new__(cls)

    def __init__(
        self,
        host: Optional[str] = None,
        port: Optional[int] = None,
        *,
        timeout: Optional[float] = 30.0,
        connect_timeout: Optional[float] = None,
        token: Optional[str] = None,
        admin_token: Optional[str] = None,
        retries: int = 0,
        retry_backoff: float = 0.05,
        use_numpy: Optional[bool] = None,
        max_line_bytes: int = 1 << 20,
        arrays: bool = False,
        connect: bool = True,
    ) -> None:
        if arrays:
            require_numpy("Client(arrays=True)")
        self._arrays = arrays
        self.host = host or os.environ.get("GEOPROX_HOST") or DEFAULT_HOST
        env_port = os.environ.get("GEOPROX_PORT")
        self.port = int(port if port is not None else (env_port or DEFAULT_PORT))
        self.timeout = timeout
        self.connect_timeout = timeout if connect_timeout is None else connect_timeout
        self._query_token = (
            token if token is not None else (os.environ.get("GEOPROX_TOKEN") or None)
        )
        self._admin_token = admin_token
        self.retries = retries
        self.retry_backoff = retry_backoff
        self.use_numpy = use_numpy
        #: The server's max_line_bytes as far as the client knows (server_info() updates it):
        #: an error reply with a null id is matched to the oldest request longer than this.
        self.max_line_bytes = max_line_bytes
        self._sock: Optional[socket.socket] = None
        self._rbuf = bytearray()
        self._scan_from = 0
        self._abandoned: set[int] = set()
        self._next_id = 1
        self._closed = False
        self._lock = threading.RLock()
        if connect:
            self.connect()

    # ---- connection ----

    @property
    def address(self) -> tuple[str, int]:
        return (self.host, self.port)

    @property
    def closed(self) -> bool:
        """True once :meth:`close` was called."""
        return self._closed

    @property
    def connected(self) -> bool:
        """True while a connection is open."""
        return self._sock is not None

    def connect(self) -> None:
        """Opens the connection if it is not open, and authenticates it when the client has a
        token. Raises :class:`GeoproxConnectionError` (reason ``ConnectionFailed``), or
        :class:`ServerError` ``Unauthorized`` for a wrong token (the client stays
        disconnected)."""
        with self._lock:
            if self._closed:
                raise GeoproxConnectionError(
                    "the client is closed", reason=Reason.CONNECTION_CLOSED
                )
            if self._sock is not None and not self._peer_closed():
                return
            self._drop()
            try:
                sock = socket.create_connection(self.address, timeout=self.connect_timeout)
            except OSError as e:
                what = "timed out" if isinstance(e, socket.timeout) else (e.strerror or str(e))
                raise GeoproxConnectionError(
                    f"cannot connect to {self.host}:{self.port}: {what}",
                    reason=Reason.CONNECTION_FAILED,
                ) from e
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            sock.setblocking(False)
            self._sock = sock
            self._rbuf.clear()
            self._scan_from = 0
            self._abandoned.clear()
            if self._query_token is not None:
                self._authenticate(self._query_token)

    def _authenticate(self, token: str) -> None:
        """``server.auth`` on the new connection, before anything else is sent on it."""
        pending = Pending(Request("server.auth", {"token": token}))
        payload, waiting, by_id = self._prepare([pending])
        try:
            self._exchange(payload, waiting, by_id, self.timeout)
            pending.result()
        except GeoproxError:
            self._drop()  # the next request connects and authenticates again
            raise

    def _peer_closed(self) -> bool:
        """True if the server closed the idle connection (its read timeout, a restart): the
        next request then goes on a new connection instead of failing."""
        assert self._sock is not None
        try:
            return self._sock.recv(1, socket.MSG_PEEK) == b""
        except (BlockingIOError, InterruptedError):
            return False  # nothing to read: alive
        except OSError:
            return True

    def _drop(self) -> None:
        """Closes the connection (the next request opens a new one, unless closed())."""
        if self._sock is not None:
            try:
                self._sock.close()
            finally:
                self._sock = None
        self._rbuf.clear()
        self._scan_from = 0
        self._abandoned.clear()

    def close(self) -> None:
        """Closes the connection for good; later requests raise GeoproxConnectionError."""
        with self._lock:
            self._closed = True
            self._drop()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self._closed else ("connected" if self._sock else "not connected")
        return f"<geoprox.Client {self.host}:{self.port} {state}>"

    # ---- requests ----

    def _submit(self, req: Request) -> Any:
        return self.call_request(req)

    def call(
        self,
        method: str,
        params: Optional[Mapping[str, Any]] = None,
        *,
        timeout: Optional[float] = None,
    ) -> Any:
        """Any method by name; returns its result or raises. ``timeout`` overrides the
        client's for this request."""
        return self.call_request(Request(method, dict(params or {})), timeout=timeout)

    def call_request(self, req: Request, *, timeout: Optional[float] = None) -> Any:
        """Sends one :class:`Request`, with the client's retries; returns its result."""
        attempt = 0
        while True:
            try:
                pending = Pending(req)
                self._run([pending], timeout if timeout is not None else self.timeout)
                result = pending.result()
                if req.method == "server.info" and isinstance(result, dict):
                    limit = result.get("limits", {}).get("max_line_bytes")
                    if isinstance(limit, int):
                        self.max_line_bytes = limit
                return result
            except GeoproxError as error:
                if (
                    attempt >= self.retries
                    or not error.retryable
                    or req.method.startswith(_ADMIN_PREFIX)
                    or self._closed
                ):
                    raise
                delay = self.retry_backoff * (2**attempt)
                if error.retry_after_ms is not None:
                    delay = max(delay, error.retry_after_ms / 1000.0)
                if error.reason == Reason.SHUTTING_DOWN:
                    with self._lock:
                        self._drop()  # reconnect: behind a balancer, to another instance
                attempt += 1
                time.sleep(delay)

    def pipeline(self, timeout: Optional[float] = None) -> Pipeline:
        """A :class:`Pipeline` on this connection. ``timeout`` bounds the whole exchange
        (default: the client's timeout)."""
        return Pipeline(self, self.timeout if timeout is None else timeout)

    def call_many(
        self,
        requests: Iterable[RequestLike],
        *,
        timeout: Optional[float] = None,
        return_exceptions: bool = False,
    ) -> list[Any]:
        """Pipelines ``requests`` (sent together, replies matched by id) and returns their
        results in order. A failed request raises its error, unless ``return_exceptions``,
        where it takes the error's place in the list."""
        pipe = self.pipeline(timeout)
        pendings = [pipe.add(r) for r in requests]
        try:
            pipe.execute()
        except GeoproxError:
            if not return_exceptions:
                raise
        return [p.outcome() if return_exceptions else p.result() for p in pendings]

    def wait_ready(
        self, mesh: Optional[str] = None, *, timeout: float = 60.0, interval: float = 0.1
    ) -> list[Result]:
        """Polls ``mesh.list`` until ``mesh`` (or every registered mesh) is ready; returns the
        ``mesh.list`` entries waited for. Connection failures count as "not yet" (the daemon
        may still be starting). Raises :class:`ServerError` ``MeshBuildFailed`` or
        ``UnknownMesh``, or :class:`GeoproxTimeoutError`."""
        deadline = time.monotonic() + timeout
        last = "no answer"
        while True:
            try:
                meshes = self.mesh_list()["meshes"]
                chosen = [m for m in meshes if mesh is None or m.get("id") == mesh]
                if mesh is not None and not chosen:
                    raise ServerError(
                        f"no mesh {mesh!r} (mesh.list has {[m.get('id') for m in meshes]})",
                        code=-32001,
                        reason=Reason.UNKNOWN_MESH,
                    )
                for m in chosen:
                    if m.get("state") == "failed":
                        raise ServerError(
                            f"mesh {m.get('id')!r} failed: {m.get('error')}",
                            code=-32003,
                            reason=Reason.MESH_BUILD_FAILED,
                        )
                if chosen and all(m.get("state") == "ready" for m in chosen):
                    return chosen
                last = ", ".join(f"{m.get('id')} {m.get('state')}" for m in chosen) or "no meshes"
            except GeoproxConnectionError as e:
                if self._closed:
                    raise
                last = str(e)
            if time.monotonic() >= deadline:
                raise GeoproxTimeoutError(f"not ready after {timeout} s ({last})")
            time.sleep(interval)

    # ---- the exchange ----

    def _decode(self, req: Request, result: Any) -> Any:
        if req.method == "geodesic.field" and isinstance(result, dict):
            result = decode_field_result(result, self.use_numpy)
            return field_arrays(result) if req.arrays else result
        if req.method == "geodesic.matrix" and isinstance(result, dict):
            result = decode_matrix_result(result, self.use_numpy)
            return matrix_arrays(result) if req.arrays else result
        if req.method == "geodesic.path" and isinstance(result, dict) and req.arrays:
            return path_arrays(result)
        if req.method == "batch" and isinstance(result, dict):
            entries = req.params.get("requests", [])
            out: list[Any] = []
            for i, item in enumerate(result.get("results", [])):
                if isinstance(item, dict) and "error" in item:
                    out.append(error_from_reply(item["error"]))
                else:
                    sub = item.get("result") if isinstance(item, dict) else None
                    method = entries[i].get("method", "") if i < len(entries) else ""
                    arrays = i < len(req.entry_arrays) and req.entry_arrays[i]
                    out.append(self._decode(Request(method, arrays=arrays), sub))
            return out
        return result

    def _run(self, pendings: list[Pending], timeout: Optional[float]) -> None:
        """Sends the requests of ``pendings`` and resolves each with its reply. Raises
        connection, timeout and protocol errors after failing the unanswered requests."""
        with self._lock:
            payload, waiting, by_id = self._prepare(pendings)
            if timeout is not None:
                slack = max((p.request.params.get("timeout_ms") or 0) for p in pendings) / 1000.0
                timeout = max(timeout, slack + 1.0) if slack else timeout
            try:
                self.connect()
                self._exchange(payload, waiting, by_id, timeout)
            except GeoproxError as error:
                for rid in waiting:
                    by_id[rid]._resolve(error=error)
                raise

    def _prepare(
        self, pendings: list[Pending]
    ) -> tuple[bytes, dict[int, int], dict[int, Pending]]:
        """The request lines of ``pendings`` with fresh ids: the payload, the ids waiting for
        a reply (id -> line length, in sending order) and their :class:`Pending`."""
        lines: list[bytes] = []
        by_id: dict[int, Pending] = {}
        waiting: dict[int, int] = {}
        for p in pendings:
            rid = self._next_id
            self._next_id += 1
            envelope: dict[str, Any] = {"jsonrpc": "2.0", "id": rid, "method": p.request.method}
            if p.request.params:
                envelope["params"] = p.request.params
            try:
                line = (
                    json.dumps(envelope, separators=(",", ":"), allow_nan=False).encode()
                    + b"\n"
                )
            except ValueError as e:  # NaN or infinity in params
                raise ValueError(
                    f"{p.request.method}: params are not valid JSON: {e}"
                ) from None
            lines.append(line)
            by_id[rid] = p
            waiting[rid] = len(line) - 1
        return b"".join(lines), waiting, by_id

    def _exchange(
        self,
        payload: bytes,
        waiting: dict[int, int],
        by_id: dict[int, Pending],
        timeout: Optional[float],
    ) -> None:
        sock = self._sock
        assert sock is not None
        out = memoryview(payload)
        sent = 0
        deadline = None if timeout is None else time.monotonic() + timeout
        selector = selectors.DefaultSelector()
        try:
            selector.register(sock, selectors.EVENT_READ | selectors.EVENT_WRITE)
            # Until every reply is in and the whole payload is out: a server may answer a line
            # before reading all of it (TooLarge), and a line left half-sent would swallow the
            # next request into it. Once every reply is in, a connection that cannot take the
            # rest of the payload is dropped, and the answers stand.
            send_error: Optional[OSError] = None  # the server stopped taking the payload
            while waiting or (sent < len(out) and send_error is None):
                remaining = None if deadline is None else deadline - time.monotonic()
                if remaining is not None and remaining <= 0:
                    if not waiting:
                        self._drop()
                        return
                    if sent < len(out):
                        self._drop()  # a half-sent line would corrupt the next request
                    else:
                        self._abandoned.update(waiting)
                    raise GeoproxTimeoutError(
                        f"no reply from {self.host}:{self.port} within {timeout} s "
                        f"({len(waiting)} of {len(by_id)} requests unanswered)"
                    )
                for _key, mask in selector.select(remaining):
                    if mask & selectors.EVENT_WRITE and sent < len(out) and send_error is None:
                        try:
                            sent += sock.send(out[sent : sent + _SEND_BYTES])
                        except (BlockingIOError, InterruptedError):
                            pass
                        except OSError as e:
                            # Its replies may be in already (TooLarge, then it hung up): read on.
                            send_error = e
                        if sent == len(out) or send_error is not None:
                            selector.modify(sock, selectors.EVENT_READ)
                    if mask & selectors.EVENT_READ:
                        try:
                            data = sock.recv(_RECV_BYTES)
                        except (BlockingIOError, InterruptedError):
                            continue
                        if not data:
                            self._drop()
                            if not waiting:
                                return
                            if send_error is not None:
                                raise send_error
                            raise GeoproxConnectionError(
                                f"connection closed by {self.host}:{self.port} "
                                f"({len(waiting)} of {len(by_id)} requests unanswered)"
                            )
                        self._rbuf += data
                        self._take_replies(waiting, by_id)
            if sent < len(out):
                self._drop()  # answered, but the rest of the payload could not be sent
        except GeoproxError:
            raise
        except OSError as e:
            self._drop()
            if not waiting:
                return
            raise GeoproxConnectionError(
                f"connection to {self.host}:{self.port} failed: {e.strerror or e}"
            ) from e
        finally:
            selector.close()

    def _take_replies(self, waiting: dict[int, int], by_id: dict[int, Pending]) -> None:
        """Parses the complete lines in the read buffer and resolves their requests."""
        buf = self._rbuf
        start, scan = 0, self._scan_from  # bytes before `scan` hold no newline
        while (end := buf.find(b"\n", scan)) >= 0:
            line = bytes(buf[start:end])
            start = scan = end + 1
            if line.strip():
                self._take_reply(line, waiting, by_id)
        del buf[:start]
        self._scan_from = len(buf)

    def _take_reply(self, line: bytes, waiting: dict[int, int], by_id: dict[int, Pending]) -> None:
        try:
            reply = json.loads(line)
        except ValueError:
            self._drop()
            raise GeoproxProtocolError(f"reply is not JSON: {line[:200]!r}") from None
        if not isinstance(reply, dict) or reply.get("jsonrpc") != "2.0" or "id" not in reply:
            self._drop()
            raise GeoproxProtocolError(f"reply is not a JSON-RPC 2.0 reply: {line[:200]!r}")
        rid = reply["id"]
        if rid is None and "error" in reply and waiting:
            # The server could not read the request's id (a line over its max_line_bytes, say):
            # the oldest request that is too long, else the oldest one.
            too_long = [i for i, n in waiting.items() if n > self.max_line_bytes]
            rid = too_long[0] if too_long else next(iter(waiting))
        if isinstance(rid, bool) or not isinstance(rid, int) or rid not in waiting:
            if isinstance(rid, int) and rid in self._abandoned:
                self._abandoned.discard(rid)  # the late reply of a request that timed out
                return
            self._drop()
            raise GeoproxProtocolError(f"reply to an unknown request id {rid!r}: {line[:200]!r}")
        del waiting[rid]
        pending = by_id[rid]
        if "error" in reply:
            pending._resolve(error=error_from_reply(reply["error"]))
        elif "result" in reply:
            try:
                pending._resolve(result=self._decode(pending.request, reply["result"]))
            except ValueError as e:
                pending._resolve(error=GeoproxProtocolError(f"{pending.request.method}: {e}"))
        else:
            pending._resolve(
                error=GeoproxProtocolError(f"reply has no result nor error: {line[:200]!r}")
            )


def _is_url(host: Any) -> bool:
    """True for a host given as a URL (``http://...``): the client is then an HttpClient."""
    return isinstance(host, str) and "://" in host


def connect(host: Optional[str] = None, port: Optional[int] = None, **options: Any) -> Client:
    """A connected :class:`Client` (same arguments; an ``http://`` URL as ``host`` gives an
    :class:`~geoprox.httpclient.HttpClient`)."""
    return Client(host, port, **options)
