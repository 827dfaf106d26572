"""geoprox: Python client of the geoprox geodesic query daemon (geoproxd).

Standard library only; numpy, if importable, decodes base64 distance fields and binary
arrays, and gives points from arrays (``geoprox.faces(f, bary)``...) and results as arrays
(``as_array=True``; :mod:`geoprox.arrays`). The wire protocol is docs/protocol.md (TCP) and
geoproxd's HTTP API (``Client("http://127.0.0.1:7880")``); docs/clients.md shows how to use
this package.

    import geoprox

    with geoprox.Client("127.0.0.1", 7878) as client:
        print(client.distance("spot", "v:0", geoprox.face(100, 0.2, 0.3, 0.5))["distance"])
"""

from .client import (
    DEFAULT_HOST,
    DEFAULT_PORT,
    Client,
    Pending,
    Pipeline,
    Request,
    RequestBuilder,
    connect,
    request,
)
from .arrays import PointSet, faces, positions, vertices
from .encoding import (
    HAVE_NUMPY,
    NOT_REACHED_SOURCE,
    decode_f32le_base64,
    decode_f64le_base64,
    decode_field_result,
    decode_matrix_result,
    decode_u32le_base64,
)
from .httpclient import DEFAULT_HTTP_PORT, BinaryArray, HttpClient
from .errors import (
    GeoproxConnectionError,
    GeoproxError,
    GeoproxProtocolError,
    GeoproxTimeoutError,
    Reason,
    ServerError,
)
from .points import (
    Point,
    as_point,
    edge,
    face,
    format_point,
    parse_point,
    position,
    sample,
    vertex,
)

__version__ = "0.1.0"

__all__ = [
    "Client",
    "HttpClient",
    "BinaryArray",
    "connect",
    "Pipeline",
    "Pending",
    "Request",
    "RequestBuilder",
    "request",
    "DEFAULT_HOST",
    "DEFAULT_PORT",
    "DEFAULT_HTTP_PORT",
    "GeoproxError",
    "GeoproxConnectionError",
    "GeoproxTimeoutError",
    "GeoproxProtocolError",
    "ServerError",
    "Reason",
    "Point",
    "vertex",
    "edge",
    "face",
    "sample",
    "position",
    "parse_point",
    "format_point",
    "as_point",
    "PointSet",
    "vertices",
    "faces",
    "positions",
    "HAVE_NUMPY",
    "NOT_REACHED_SOURCE",
    "decode_f32le_base64",
    "decode_f64le_base64",
    "decode_u32le_base64",
    "decode_field_result",
    "decode_matrix_result",
    "__version__",
]
