"""The HTTP transport of the geoprox client: JSON-RPC 2.0 over geoproxd's HTTP API.

``geoprox.Client("http://127.0.0.1:7880")`` is an :class:`HttpClient`: the same methods, results
and errors as the TCP client, carried by ``POST /v1/rpc`` (one JSON-RPC request per HTTP request,
a JSON-RPC batch array per pipeline) on one keep-alive connection of the standard library's
:mod:`http.client`. The query token travels as ``Authorization: Bearer``.

Errors are the same :class:`~geoprox.errors.GeoproxError` subclasses as over TCP: the reason comes
from the JSON error object of the reply; the HTTP status decides it only when the body has none
(a proxy's error page, a transport-level refusal such as 413 or 431). A keep-alive connection that
the server closed is replaced before the request is sent; one found closed by the request itself
is replaced and the request sent again once, when repeating it is harmless (every method but the
admin ones).

:meth:`HttpClient.array` fetches one array of a field, a matrix or a mesh's geometry from the
resource endpoints as raw little-endian binary (no JSON, no base64, float64 by default). Matrices
and one-source fields asked for with ``as_array`` come that way too; fields of several sources
(whose ``nearest_source`` is a second array) come through ``/v1/rpc`` in ``"f64le-base64"``.
"""

from __future__ import annotations

import array as _array
import http.client
import json
import math
import os
import select
import socket
import sys
import urllib.parse
from dataclasses import dataclass
from typing import Any, Mapping, Optional

from .client import _ADMIN_PREFIX, Client, Pending, Request
from .encoding import HAVE_NUMPY, _np
from .errors import (
    GeoproxConnectionError,
    GeoproxError,
    GeoproxProtocolError,
    GeoproxTimeoutError,
    Reason,
    ServerError,
    error_from_reply,
)

__all__ = ["HttpClient", "BinaryArray", "DEFAULT_HTTP_PORT", "RPC_PATH"]

DEFAULT_HTTP_PORT = 7880
RPC_PATH = "/v1/rpc"

# The reason (and its JSON-RPC code and retryability) of an HTTP error status whose body carries
# no JSON error object: the table of the HTTP API, read backwards, for replies that did not come
# from geoproxd's JSON-RPC layer (transport-level refusals, proxies).
_STATUS_REASONS: dict[int, tuple[str, int, bool]] = {
    400: (Reason.INVALID_REQUEST, -32600, False),
    401: (Reason.UNAUTHORIZED, -32040, False),
    403: (Reason.UNAUTHORIZED, -32040, False),
    404: (Reason.NOT_FOUND, -32006, False),
    408: (Reason.DEADLINE_EXCEEDED, -32031, True),
    409: (Reason.MESH_EXISTS, -32004, False),
    413: (Reason.TOO_LARGE, -32020, False),
    422: (Reason.UNREACHABLE, -32010, False),
    429: (Reason.OVERLOADED, -32030, True),
    431: (Reason.TOO_LARGE, -32020, False),
    500: (Reason.INTERNAL, -32603, True),
    503: (Reason.SHUTTING_DOWN, -32032, True),
    504: (Reason.DEADLINE_EXCEEDED, -32031, True),
}

# A keep-alive connection found closed when the request is sent or its reply awaited.
_DROPPED = (ConnectionResetError, BrokenPipeError, ConnectionAbortedError)

_DTYPES = {"float64": ("d", "<f8", 8), "float32": ("f", "<f4", 4), "uint32": (None, "<u4", 4)}
_U32_TYPECODE = "I" if _array.array("I").itemsize == 4 else "L"


def _idempotent(req: Request) -> bool:
    """True when sending ``req`` twice does no harm: every method but the admin ones."""
    if req.method.startswith(_ADMIN_PREFIX):
        return False
    if req.method == "batch":
        entries = req.params.get("requests") or []
        return all(
            not str(e.get("method", "")).startswith(_ADMIN_PREFIX)
            for e in entries
            if isinstance(e, Mapping)
        )
    return True


# Methods whose replies may be large: a pipeline sends them alone, not in a batch array, whose
# replies together are bounded by the server's max_output_bytes.
_ALONE = frozenset({"geodesic.field", "geodesic.matrix", "geodesic.expmap", "batch"})


def _points(req: Request) -> int:
    """The points a request names, as the server counts them against max_points_per_request."""
    if req.method == "batch":
        entries = req.params.get("requests") or []
        return sum(
            _points(Request(str(e.get("method", "")), dict(e.get("params") or {})))
            for e in entries
            if isinstance(e, Mapping)
        )
    count = 0
    for key in ("source", "target"):
        count += key in req.params
    for key in ("sources", "targets", "control"):
        value = req.params.get(key)
        count += len(value) if isinstance(value, (list, tuple)) else 0
    return count


def _retry_after_ms(headers: http.client.HTTPMessage) -> Optional[int]:
    value = headers.get("Retry-After")
    try:
        return None if value is None else max(0, int(value)) * 1000
    except ValueError:
        return None


@dataclass(frozen=True)
class BinaryArray:
    """One array from a resource endpoint (:meth:`HttpClient.array`).

    ``values`` is a numpy array of ``shape`` when numpy is used, else a flat
    :class:`array.array` in C order (row ``i`` of a matrix is ``values[i * cols:(i + 1) * cols]``).
    Unreachable or beyond-cutoff distances are NaN; ``nearest_source`` is 4294967295 where no
    source reached."""

    values: Any
    shape: tuple[int, ...]
    dtype: str
    mesh_version: Optional[str]


class _Reply:
    def __init__(self, status: int, reason: str, headers: http.client.HTTPMessage, body: bytes):
        self.status, self.reason, self.headers, self.body = status, reason, headers, body

    def json(self) -> Any:
        try:
            return json.loads(self.body)
        except ValueError:
            return None

    def status_error(self) -> ServerError:
        """The error of a non-2xx reply without a JSON error object, from its status."""
        reason, code, retryable = _STATUS_REASONS.get(
            self.status,
            (Reason.INTERNAL, -32603, True)
            if self.status >= 500
            else (Reason.INVALID_REQUEST, -32600, False),
        )
        text = self.body[:200].decode("utf-8", "replace").strip()
        retry_after_ms = _retry_after_ms(self.headers)
        data: dict[str, Any] = {"reason": reason, "retryable": retryable}
        if retry_after_ms is not None:
            data["retry_after_ms"] = retry_after_ms
        out = ServerError(
            f"HTTP {self.status} {self.reason}" + (f": {text}" if text else ""),
            code=code,
            reason=reason,
            retryable=retryable,
            retry_after_ms=retry_after_ms,
            data=data,  # as the server's error object would have it
        )
        out.http_status = self.status
        return out

    def error(self, error: Any, *, whole: bool = True) -> ServerError:
        """The :class:`ServerError` of a JSON error object; ``whole``: the error is the whole
        reply's (not an entry's of a batch array), so its status and Retry-After are too."""
        out = error_from_reply(error)
        if whole:
            out.http_status = self.status
            if out.retry_after_ms is None:
                out.retry_after_ms = _retry_after_ms(self.headers)
        return out


class HttpClient(Client):
    """A client of geoproxd's HTTP port: ``geoprox.Client("http://host:7880")`` makes one.

    Args:
        url: ``http://host[:port][/prefix]``: the port defaults to ``port``, else 7880; a path
            prefix is put before ``/v1/...`` (a reverse proxy's). ``https`` is not supported.
        port: the port when the URL has none.
        Every other argument is the TCP client's (:class:`geoprox.Client`). ``token`` (default
        ``GEOPROX_TOKEN``) is sent as ``Authorization: Bearer`` with every request: a wrong or
        missing one is :class:`ServerError` ``Unauthorized`` at the first request, not at
        connect. ``timeout`` bounds each wait for the server; past it the connection is closed
        (a late reply cannot be told from the next one) and the next request opens another.

    :meth:`pipeline` and :meth:`call_many` send the queued requests as JSON-RPC batch arrays,
    each within the server's limits on a whole array: ``max_batch_requests`` requests,
    ``max_line_bytes`` bytes and ``max_points_per_request`` points (``server_info()`` updates
    them; a request over a limit by itself goes alone and gets its own ``TooLarge``). Fields,
    matrices, exponential maps and ``batch`` calls go alone too (the replies of an array share
    one ``max_output_bytes``). To a server that refuses batch arrays, requests are sent one
    after another instead.
    """

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
        max_batch_requests: int = 1000,
        arrays: bool = False,
        connect: bool = True,
    ) -> None:
        self.url = host or os.environ.get("GEOPROX_HOST") or ""
        parts = urllib.parse.urlsplit(self.url)
        if parts.scheme.lower() != "http":
            raise ValueError(f"not an http:// URL: {self.url!r} (https is not supported)")
        if not parts.hostname or parts.query or parts.fragment:
            raise ValueError(f"expected http://host[:port][/prefix], got {self.url!r}")
        url_port = parts.port  # raises ValueError for a bad port
        self.prefix = parts.path.rstrip("/")
        super().__init__(
            parts.hostname,
            url_port if url_port is not None else (port or DEFAULT_HTTP_PORT),
            timeout=timeout,
            connect_timeout=connect_timeout,
            token=token,
            admin_token=admin_token,
            retries=retries,
            retry_backoff=retry_backoff,
            use_numpy=use_numpy,
            max_line_bytes=max_line_bytes,
            arrays=arrays,
            connect=False,
        )
        #: The server's max_batch_requests as far as the client knows (server_info() updates it).
        self.max_batch_requests = max_batch_requests
        #: The server's max_points_per_request, which bounds the points of a whole batch array.
        self.max_points_per_request = 10000
        self._conn: Optional[http.client.HTTPConnection] = None
        self._conn_used = False  # the connection has carried a reply: it may have gone stale
        self._batch_arrays = True  # False once the server refused a batch array
        if connect:
            self.connect()

    # ---- connection ----

    @property
    def connected(self) -> bool:
        return self._conn is not None and self._conn.sock is not None

    def connect(self) -> None:
        """Opens the keep-alive connection unless one is open (the server's idle timeout or a
        restart may have closed it: then another). Raises :class:`GeoproxConnectionError`
        (reason ``ConnectionFailed``)."""
        with self._lock:
            if self._closed:
                raise GeoproxConnectionError(
                    "the client is closed", reason=Reason.CONNECTION_CLOSED
                )
            if self.connected and not self._peer_closed():
                return
            self._drop()
            conn = http.client.HTTPConnection(self.host, self.port, timeout=self.connect_timeout)
            try:
                conn.connect()
            except OSError as e:
                conn.close()
                what = "timed out" if isinstance(e, socket.timeout) else (e.strerror or str(e))
                raise GeoproxConnectionError(
                    f"cannot connect to {self.url_of('')}: {what}",
                    reason=Reason.CONNECTION_FAILED,
                ) from e
            assert conn.sock is not None
            conn.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self._conn, self._conn_used = conn, False

    def _peer_closed(self) -> bool:
        """True if the idle connection has something to read: the server closed it (its idle
        timeout, a restart) or said something unasked; either way it is not usable."""
        assert self._conn is not None and self._conn.sock is not None
        try:
            readable, _, _ = select.select([self._conn.sock], [], [], 0)
        except (OSError, ValueError):
            return True
        return bool(readable)

    @property
    def socket(self) -> Optional[socket.socket]:
        """The socket of the keep-alive connection, or None."""
        return None if self._conn is None else self._conn.sock

    def _drop(self) -> None:
        if self._conn is not None:
            try:
                self._conn.close()
            finally:
                self._conn = None

    def url_of(self, path: str) -> str:
        """The URL of ``path`` (``/v1/rpc``...) on this server."""
        return f"http://{self.host}:{self.port}{self.prefix}{path}"

    def __repr__(self) -> str:
        state = "closed" if self._closed else ("connected" if self.connected else "not connected")
        return f"<geoprox.HttpClient {self.url_of('')} {state}>"

    # ---- one HTTP exchange ----

    def _http(
        self,
        method: str,
        path: str,
        body: Optional[bytes],
        headers: Mapping[str, str],
        *,
        idempotent: bool,
        timeout: Optional[float],
    ) -> _Reply:
        """One request and its reply on the keep-alive connection. A connection that turns out
        closed is replaced, and an idempotent request sent again on the new one, once."""
        all_headers = {"Accept": "application/json", **headers}
        if self._query_token is not None:
            all_headers["Authorization"] = f"Bearer {self._query_token}"
        if body is not None:
            all_headers.setdefault("Content-Type", "application/json")
        target = f"{self.prefix}{path}"
        while True:
            self.connect()
            conn = self._conn
            assert conn is not None and conn.sock is not None
            reused = self._conn_used
            try:
                conn.sock.settimeout(timeout)
                send_error: Optional[OSError] = None
                try:
                    conn.request(method, target, body=body, headers=all_headers)
                except _DROPPED as e:
                    # The server may have answered before it stopped reading (413): read on.
                    send_error = e
                try:
                    response = conn.getresponse()
                    data = response.read()
                except (OSError, http.client.HTTPException):
                    if send_error is None:
                        raise
                    raise send_error from None
            except socket.timeout:
                self._drop()  # its late reply would be taken for the next request's
                raise GeoproxTimeoutError(
                    f"no reply from {self.url_of(path)} within {timeout} s"
                ) from None
            except _DROPPED as e:  # http.client.RemoteDisconnected included
                self._drop()
                if reused and idempotent:
                    continue  # a stale keep-alive connection: once more on a new one
                raise GeoproxConnectionError(
                    f"connection closed by {self.host}:{self.port} before its reply to "
                    f"{method} {path} ({e.__class__.__name__})"
                ) from e
            except http.client.HTTPException as e:
                self._drop()
                if isinstance(e, http.client.IncompleteRead):
                    raise GeoproxConnectionError(
                        f"connection closed by {self.host}:{self.port} in the middle of its "
                        f"reply to {method} {path}"
                    ) from e
                raise GeoproxProtocolError(f"{method} {path}: not an HTTP reply: {e!r}") from e
            except OSError as e:
                self._drop()
                raise GeoproxConnectionError(
                    f"connection to {self.host}:{self.port} failed: {e.strerror or e}"
                ) from e
            if conn.sock is None:  # "Connection: close": http.client closed it
                self._drop()
            else:
                self._conn_used = True
            return _Reply(response.status, response.reason, response.headers, data)

    # ---- JSON-RPC over POST /v1/rpc ----

    def _envelope(self, req: Request) -> tuple[int, bytes]:
        rid = self._next_id
        self._next_id += 1
        envelope: dict[str, Any] = {"jsonrpc": "2.0", "id": rid, "method": req.method}
        if req.params:
            envelope["params"] = req.params
        try:
            return rid, json.dumps(envelope, separators=(",", ":"), allow_nan=False).encode()
        except ValueError as e:  # NaN or infinity in params
            raise ValueError(f"{req.method}: params are not valid JSON: {e}") from None

    def _run(self, pendings: list[Pending], timeout: Optional[float]) -> None:
        """Sends the requests of ``pendings`` and resolves each with its reply. Raises
        connection, timeout and protocol errors after failing the unanswered requests."""
        with self._lock:
            binary = [p for p in pendings if _binary_route(p.request)]
            encoded = [
                (p, *self._envelope(p.request)) for p in pendings if not _binary_route(p.request)
            ]
            if timeout is not None:
                slack = max((p.request.params.get("timeout_ms") or 0) for p in pendings) / 1000.0
                timeout = max(timeout, slack + 1.0) if slack else timeout
            try:
                for pending in binary:
                    self._run_binary(pending, timeout)
                for chunk in self._chunks(encoded):
                    self._run_chunk(chunk, timeout)
            except GeoproxError as error:
                for p in pendings:
                    if not p.done():
                        p._resolve(error=error)
                raise

    def _run_binary(self, pending: Pending, timeout: Optional[float]) -> None:
        """A matrix or one-source field wanted as arrays, from its resource endpoint as raw
        float64: the result dict :func:`~geoprox.arrays.matrix_arrays` or
        :func:`~geoprox.arrays.field_arrays` makes of the JSON one."""
        req = pending.request
        params = {k: v for k, v in req.params.items() if k not in ("mesh", "encoding")}
        mesh = str(req.params.get("mesh", ""))
        is_matrix = req.method == "geodesic.matrix"
        try:
            got = self.array(mesh, "matrix" if is_matrix else "field", params,
                             dtype="float64", timeout=timeout)
        except ServerError as error:
            pending._resolve(error=error)
            return
        np = _np
        if got.dtype != "float64":
            raise GeoproxProtocolError(f"{req.method}: binary reply of {got.dtype}, not float64")
        # A flat array.array when the client has use_numpy=False: arrays were asked for.
        values = np.asarray(got.values, dtype=np.float64).reshape(got.shape)
        reachable = int(np.isfinite(values).sum())
        result: dict[str, Any] = {"mesh": mesh, "mesh_version": got.mesh_version}
        if is_matrix:
            if len(got.shape) != 2:
                raise GeoproxProtocolError(f"matrix of shape {got.shape}")
            result.update(sources=got.shape[0], targets=got.shape[1],
                          unreachable=values.size - reachable, distances=values)
        else:
            result.update(vertices=values.size, reached=reachable,
                          cutoff=req.params.get("cutoff"), distances=values)
        pending._resolve(result=result)

    def _chunks(
        self, encoded: list[tuple[Pending, int, bytes]]
    ) -> list[list[tuple[Pending, int, bytes]]]:
        """Groups requests into batch arrays, in order, within the limits the server puts on
        a whole array (requests, bytes, points). Requests that may answer much (fields,
        matrices...) go alone: an array's replies share one max_output_bytes."""
        chunks: list[list[tuple[Pending, int, bytes]]] = []
        size = points = 0
        alone = False  # the last chunk holds a request that goes alone
        for item in encoded:
            n = len(item[2]) + 1  # and a comma or a bracket
            k = _points(item[0].request)
            this_alone = item[0].request.method in _ALONE
            if (
                not chunks
                or alone
                or this_alone
                or len(chunks[-1]) >= self.max_batch_requests
                or size + n + 1 > self.max_line_bytes
                or points + k > self.max_points_per_request
            ):
                chunks.append([])
                size = 1
                points = 0
            chunks[-1].append(item)
            size += n
            points += k
            alone = this_alone
        return chunks

    def _run_chunk(self, chunk: list[tuple[Pending, int, bytes]], timeout: Optional[float]) -> None:
        idempotent = all(_idempotent(p.request) for p, _, _ in chunk)
        if len(chunk) == 1 or not self._batch_arrays:
            for pending, rid, body in chunk:
                reply = self._post_rpc(body, idempotent=_idempotent(pending.request),
                                       timeout=timeout)
                self._take_single(reply, pending, rid)
            return
        body = b"[" + b",".join(b for _, _, b in chunk) + b"]"
        reply = self._post_rpc(body, idempotent=idempotent, timeout=timeout)
        document = reply.json()
        if isinstance(document, list):
            self._take_array(reply, document, chunk)
            return
        if isinstance(document, dict) and isinstance(document.get("error"), dict):
            error = reply.error(document["error"])
            if error.reason == Reason.INVALID_REQUEST and document.get("id") is None:
                # A server without JSON-RPC batch arrays: one request at a time from now on.
                self._batch_arrays = False
                self._run_chunk(chunk, timeout)
                return
            for pending, _, _ in chunk:  # refused whole (TooLarge, Unauthorized...)
                pending._resolve(error=error)
            return
        self._fail_reply(reply, [p for p, _, _ in chunk])

    def _post_rpc(self, body: bytes, *, idempotent: bool, timeout: Optional[float]) -> _Reply:
        return self._http(
            "POST", RPC_PATH, body, {}, idempotent=idempotent, timeout=timeout
        )

    def _fail_reply(self, reply: _Reply, pendings: list[Pending]) -> None:
        """Resolves ``pendings`` with the error of a reply that has no JSON-RPC response."""
        if 200 <= reply.status < 300:
            raise GeoproxProtocolError(
                f"POST {RPC_PATH}: HTTP {reply.status} without a JSON-RPC response: "
                f"{reply.body[:200]!r}"
            )
        document = reply.json()
        if isinstance(document, dict) and isinstance(document.get("error"), dict):
            error = reply.error(document["error"])
        else:
            error = reply.status_error()
        for pending in pendings:
            pending._resolve(error=error)

    def _resolve(
        self, reply: _Reply, pending: Pending, response: Mapping[str, Any], whole: bool = True
    ) -> None:
        if "error" in response:
            pending._resolve(error=reply.error(response["error"], whole=whole))
        elif "result" in response:
            try:
                pending._resolve(result=self._decode(pending.request, response["result"]))
            except ValueError as e:
                pending._resolve(error=GeoproxProtocolError(f"{pending.request.method}: {e}"))
        else:
            pending._resolve(
                error=GeoproxProtocolError(f"reply has no result nor error: {response!r:.200}")
            )

    def _take_single(self, reply: _Reply, pending: Pending, rid: int) -> None:
        document = reply.json()
        if (
            isinstance(document, dict)
            and document.get("jsonrpc") == "2.0"
            and ("result" in document or "error" in document)
        ):
            got = document.get("id")
            if got != rid and not (got is None and "error" in document):
                raise GeoproxProtocolError(
                    f"reply to request id {rid} has id {got!r}: {reply.body[:200]!r}"
                )
            self._resolve(reply, pending, document)
        else:
            self._fail_reply(reply, [pending])

    def _take_array(
        self, reply: _Reply, responses: list[Any], chunk: list[tuple[Pending, int, bytes]]
    ) -> None:
        by_id = {rid: pending for pending, rid, _ in chunk}
        # An array refused whole (429 Overloaded, 503 ShuttingDown: every element the same
        # error) has a status and Retry-After of its own; one answered has 200 for all.
        whole = reply.status != 200
        anonymous: list[Mapping[str, Any]] = []  # errors with id null: matched in order
        for response in responses:
            if not isinstance(response, dict) or response.get("jsonrpc") != "2.0":
                raise GeoproxProtocolError(f"not a JSON-RPC 2.0 response: {response!r:.200}")
            rid = response.get("id")
            if rid is None and "error" in response:
                anonymous.append(response)
                continue
            if isinstance(rid, bool) or rid not in by_id:
                raise GeoproxProtocolError(f"response to an unknown request id {rid!r}")
            self._resolve(reply, by_id.pop(rid), response, whole=whole)
        for pending in by_id.values():
            if anonymous:
                self._resolve(reply, pending, anonymous.pop(0), whole=whole)
            else:
                pending._resolve(
                    error=GeoproxProtocolError(
                        f"the batch reply has no response to {pending.request.method}"
                    )
                )

    def call_request(self, req: Request, *, timeout: Optional[float] = None) -> Any:
        result = super().call_request(req, timeout=timeout)
        if req.method == "server.info" and isinstance(result, dict):
            limit = result.get("limits", {}).get("max_batch_requests")
            if isinstance(limit, int) and limit > 0:
                self.max_batch_requests = limit
            limit = result.get("limits", {}).get("max_points_per_request")
            if isinstance(limit, int) and limit > 0:
                self.max_points_per_request = limit
        return result

    # ---- binary arrays from the resource endpoints ----

    def array(
        self,
        mesh: str,
        what: str,
        params: Optional[Mapping[str, Any]] = None,
        *,
        array: Optional[str] = None,
        dtype: Optional[str] = None,
        timeout: Optional[float] = None,
    ) -> BinaryArray:
        """One array of ``what`` (``"field"``, ``"matrix"`` or ``"geometry"``) on ``mesh``, as
        raw little-endian binary (``Accept: application/octet-stream``).

        ``params`` are the method's params without ``mesh`` (points in any form the methods
        take), ``array`` picks ``"distances"`` (default), ``"nearest_source"``,
        ``"positions"`` or ``"triangles"``, ``dtype`` ``"float64"`` (default) or
        ``"float32"``. Unlike ``field()``, nothing is lost to float32 or JSON."""
        from .points import as_point

        body: dict[str, Any] = {}
        for key, value in (params or {}).items():
            if key in ("source", "target"):
                value = as_point(value)
            elif key in ("sources", "targets"):
                value = [as_point(p) for p in value]
            body[key] = value
        query = {k: v for k, v in (("array", array), ("dtype", dtype)) if v is not None}
        path = f"/v1/meshes/{urllib.parse.quote(mesh, safe='')}/{what}"
        if query:
            path += "?" + urllib.parse.urlencode(query)
        with self._lock:
            if what == "geometry":
                method, payload = "GET", None
            else:
                method = "POST"
                payload = json.dumps(body, separators=(",", ":"), allow_nan=False).encode()
            reply = self._http(
                method,
                path,
                payload,
                {"Accept": "application/octet-stream"},
                idempotent=True,
                timeout=self.timeout if timeout is None else timeout,
            )
        if reply.status != 200:
            document = reply.json()
            if isinstance(document, dict) and isinstance(document.get("error"), dict):
                raise reply.error(document["error"])
            raise reply.status_error()
        return _binary_array(reply, self.use_numpy)


def _binary_route(req: Request) -> bool:
    """True for a request whose arrays come from a resource endpoint as raw float64: a matrix,
    or a field of one source, asked for with ``as_array``."""
    if not req.arrays:
        return False
    if req.method == "geodesic.matrix":
        return True
    return req.method == "geodesic.field" and "source" in req.params


def _binary_array(reply: _Reply, use_numpy: Optional[bool]) -> BinaryArray:
    dtype = reply.headers.get("X-Geoprox-Dtype", "")
    if dtype not in _DTYPES:
        raise GeoproxProtocolError(f"binary reply with X-Geoprox-Dtype {dtype!r}")
    try:
        shape = tuple(int(n) for n in reply.headers.get("X-Geoprox-Shape", "").split(","))
    except ValueError:
        raise GeoproxProtocolError(
            f"binary reply with X-Geoprox-Shape {reply.headers.get('X-Geoprox-Shape')!r}"
        ) from None
    typecode, numpy_dtype, size = _DTYPES[dtype]
    if len(reply.body) != size * math.prod(shape):
        raise GeoproxProtocolError(
            f"binary reply of {len(reply.body)} bytes for {dtype} of shape {shape}"
        )
    if use_numpy and not HAVE_NUMPY:
        raise RuntimeError("numpy was asked for but cannot be imported")
    if HAVE_NUMPY if use_numpy is None else use_numpy:
        values = _np.frombuffer(reply.body, dtype=numpy_dtype).astype(numpy_dtype[1:])
        values = values.reshape(shape)
    else:
        values = _array.array(typecode or _U32_TYPECODE)
        values.frombytes(reply.body)
        if sys.byteorder == "big":
            values.byteswap()
    return BinaryArray(values, shape, dtype, reply.headers.get("X-Geoprox-Mesh-Version"))

