"""Exceptions of the geoprox client.

Every exception the client raises for a failed request is a :class:`GeoproxError`; it carries
the JSON-RPC ``code``, the stable ``reason`` name, ``retryable`` and ``retry_after_ms`` of
docs/protocol.md ("Replies and errors"). Errors found by the client itself (the connection
failed, no reply in time, a reply that is not JSON-RPC) use ``code`` None and a reason of their
own: ``ConnectionFailed``, ``ConnectionClosed``, ``Timeout``, ``BadReply``.

Switch on ``error.reason`` (or ``error.is_reason("UnknownMesh", ...)``), never on the message.
Unknown reasons are to be treated by ``code`` and ``retryable``.
"""

from __future__ import annotations

import builtins
from typing import Any, Mapping, Optional

__all__ = [
    "GeoproxError",
    "GeoproxConnectionError",
    "GeoproxTimeoutError",
    "GeoproxProtocolError",
    "ServerError",
    "Reason",
    "error_from_reply",
]


class Reason:
    """The reason names of docs/protocol.md, as constants (``Reason.UNKNOWN_MESH``...)."""

    PARSE_ERROR = "ParseError"
    INVALID_REQUEST = "InvalidRequest"
    UNKNOWN_METHOD = "UnknownMethod"
    INVALID_PARAMS = "InvalidParams"
    BAD_POINT = "BadPoint"
    BAD_BARYCENTRIC = "BadBarycentric"
    BAD_EDGE_PARAMETER = "BadEdgeParameter"
    VERTEX_OUT_OF_RANGE = "VertexOutOfRange"
    EDGE_OUT_OF_RANGE = "EdgeOutOfRange"
    FACE_OUT_OF_RANGE = "FaceOutOfRange"
    SAMPLE_OUT_OF_RANGE = "SampleOutOfRange"
    ISOLATED_VERTEX = "IsolatedVertex"
    PATH_NOT_ALLOWED = "PathNotAllowed"
    UNKNOWN_MESH = "UnknownMesh"
    MESH_NOT_READY = "MeshNotReady"
    MESH_BUILD_FAILED = "MeshBuildFailed"
    MESH_EXISTS = "MeshExists"
    BAD_MESH_FILE = "BadMeshFile"
    NOT_FOUND = "NotFound"
    UNREACHABLE = "Unreachable"
    TOO_LARGE = "TooLarge"
    RESOURCE_EXHAUSTED = "ResourceExhausted"
    OVERLOADED = "Overloaded"
    DEADLINE_EXCEEDED = "DeadlineExceeded"
    SHUTTING_DOWN = "ShuttingDown"
    UNAUTHORIZED = "Unauthorized"
    INTERNAL = "Internal"
    # Found by the client, not sent by the server.
    CONNECTION_FAILED = "ConnectionFailed"
    CONNECTION_CLOSED = "ConnectionClosed"
    TIMEOUT = "Timeout"
    BAD_REPLY = "BadReply"


class GeoproxError(Exception):
    """Base class of every error of the geoprox client.

    Attributes:
        message: what went wrong, for humans.
        code: the JSON-RPC error code, or None for errors found by the client.
        reason: the stable CamelCase reason (see :class:`Reason`).
        retryable: whether the same request may succeed later unchanged.
        retry_after_ms: how long to wait before retrying, when the server says so.
        data: the whole ``error.data`` object of the reply (empty for client errors).
        http_status: the HTTP status of the reply that carried the error (HTTP transport:
            401 or 403 for ``Unauthorized``...), else None.
    """

    http_status: Optional[int] = None

    def __init__(
        self,
        message: str,
        *,
        code: Optional[int] = None,
        reason: str = "",
        retryable: bool = False,
        retry_after_ms: Optional[int] = None,
        data: Optional[Mapping[str, Any]] = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.code = code
        self.reason = reason
        self.retryable = retryable
        self.retry_after_ms = retry_after_ms
        self.data: dict[str, Any] = dict(data or {})

    def is_reason(self, *reasons: str) -> bool:
        """True if :attr:`reason` is one of ``reasons``."""
        return self.reason in reasons

    def __str__(self) -> str:
        return f"{self.message} [{self.reason}]" if self.reason else self.message

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}({self.message!r}, code={self.code!r}, "
            f"reason={self.reason!r}, retryable={self.retryable!r})"
        )


class GeoproxConnectionError(GeoproxError, builtins.ConnectionError):
    """The connection could not be opened, was closed, or broke (reasons ``ConnectionFailed``,
    ``ConnectionClosed``). Also a built-in :class:`ConnectionError`. Retryable: the request may
    succeed on a new connection (the client opens one on the next call)."""

    def __init__(self, message: str, *, reason: str = Reason.CONNECTION_CLOSED) -> None:
        super().__init__(message, reason=reason, retryable=True)


class GeoproxTimeoutError(GeoproxError, builtins.TimeoutError):
    """No reply came within the client's timeout (reason ``Timeout``). Also a built-in
    :class:`TimeoutError`. The server's own deadline (``timeout_ms``) is a :class:`ServerError`
    with reason ``DeadlineExceeded`` instead."""

    def __init__(self, message: str) -> None:
        super().__init__(message, reason=Reason.TIMEOUT, retryable=True)


class GeoproxProtocolError(GeoproxError):
    """The server sent something that is not a valid reply (reason ``BadReply``); the client
    closes the connection."""

    def __init__(self, message: str) -> None:
        super().__init__(message, reason=Reason.BAD_REPLY, retryable=False)


class ServerError(GeoproxError):
    """The server answered the request with a JSON-RPC error object."""


def error_from_reply(error: Any) -> ServerError:
    """The :class:`ServerError` of a reply's ``error`` object (tolerating odd shapes)."""
    if not isinstance(error, Mapping):
        return ServerError(f"malformed error object: {error!r}", reason=Reason.BAD_REPLY)
    data = error.get("data")
    data = data if isinstance(data, Mapping) else {}
    code = error.get("code")
    retry_after = data.get("retry_after_ms")
    return ServerError(
        str(error.get("message", "")),
        code=code if isinstance(code, int) else None,
        reason=str(data.get("reason", "")),
        retryable=bool(data.get("retryable", False)),
        retry_after_ms=retry_after if isinstance(retry_after, int) else None,
        data=data,
    )
