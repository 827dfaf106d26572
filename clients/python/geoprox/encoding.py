"""Decoding of ``geodesic.field`` and ``geodesic.matrix`` results (docs/protocol.md,
"Encodings").

With ``"f32le-base64"`` the distances are IEEE-754 binary32 values, little-endian, in base64
(``+inf`` where not reached) and ``nearest_source`` unsigned 32-bit little-endian integers
(``0xFFFFFFFF`` where not reached). They are decoded into a numpy array (``float32``,
``uint32``) when numpy can be imported, else into an :class:`array.array` (typecode ``'f'``,
and an unsigned 4-byte typecode for the indices). ``"f64le-base64"`` is the same with binary64
values (``float64`` arrays, typecode ``'d'``): the very doubles of the JSON numbers. A matrix in
``"f64le-base64"`` is decoded into a 2-D ``float64`` array (without numpy, a list of rows, each
an ``array('d')``). With ``"json"`` they stay lists (``None`` where not reached).
"""

from __future__ import annotations

import array
import base64
import binascii
import sys
from typing import Any, Optional

__all__ = [
    "HAVE_NUMPY",
    "NOT_REACHED_SOURCE",
    "decode_f32le_base64",
    "decode_f64le_base64",
    "decode_u32le_base64",
    "decode_field_result",
    "decode_matrix_result",
]

_np: Any
try:  # numpy is optional
    import numpy as _np
except ImportError:  # pragma: no cover - depends on the environment
    _np = None

#: True when numpy is importable (field arrays are then numpy arrays by default).
HAVE_NUMPY: bool = _np is not None

#: ``nearest_source`` entry of a vertex that no source reached, with the base64 encoding.
NOT_REACHED_SOURCE = 0xFFFFFFFF

_U32_TYPECODE = "I" if array.array("I").itemsize == 4 else "L"


def _bytes_of(text: str, what: str, width: int = 4) -> bytes:
    try:
        raw = base64.b64decode(text, validate=True)
    except (binascii.Error, ValueError, TypeError) as e:
        raise ValueError(f"{what}: not valid base64: {e}") from None
    if len(raw) % width:
        raise ValueError(
            f"{what}: {len(raw)} bytes is not a whole number of {8 * width}-bit values"
        )
    return raw


def _use_numpy(use_numpy: Optional[bool]) -> bool:
    if use_numpy and _np is None:
        raise RuntimeError("numpy was asked for but cannot be imported")
    return HAVE_NUMPY if use_numpy is None else use_numpy


def decode_f32le_base64(text: str, use_numpy: Optional[bool] = None) -> Any:
    """Float32 values from base64: a numpy ``float32`` array, or ``array.array('f')``.

    ``use_numpy`` None picks numpy when it is importable; True requires it; False never uses it.
    """
    raw = _bytes_of(text, "distances")
    if _use_numpy(use_numpy):
        return _np.frombuffer(raw, dtype="<f4").astype(_np.float32)  # native order, writable
    values = array.array("f")
    values.frombytes(raw)
    if sys.byteorder == "big":
        values.byteswap()
    return values


def decode_f64le_base64(text: str, use_numpy: Optional[bool] = None) -> Any:
    """Float64 values from base64: a numpy ``float64`` array, or ``array.array('d')``; every
    value bit for bit as the server computed it (``inf`` where not reached)."""
    raw = _bytes_of(text, "distances", 8)
    if _use_numpy(use_numpy):
        return _np.frombuffer(raw, dtype="<f8").astype(_np.float64)
    values = array.array("d")
    values.frombytes(raw)
    if sys.byteorder == "big":
        values.byteswap()
    return values


def decode_u32le_base64(text: str, use_numpy: Optional[bool] = None) -> Any:
    """Unsigned 32-bit integers from base64: a numpy ``uint32`` array or an ``array.array``."""
    raw = _bytes_of(text, "nearest_source")
    if _use_numpy(use_numpy):
        return _np.frombuffer(raw, dtype="<u4").astype(_np.uint32)
    values = array.array(_U32_TYPECODE)
    values.frombytes(raw)
    if sys.byteorder == "big":
        values.byteswap()
    return values


def decode_field_result(result: dict[str, Any], use_numpy: Optional[bool] = None) -> dict[str, Any]:
    """Decodes a ``geodesic.field`` result in place (base64 members become arrays) and
    returns it. JSON-encoded results are returned unchanged."""
    encoding = result.get("encoding")
    if encoding in ("f32le-base64", "f64le-base64"):
        if isinstance(result.get("distances"), str):
            decode = decode_f32le_base64 if encoding == "f32le-base64" else decode_f64le_base64
            result["distances"] = decode(result["distances"], use_numpy)
        if isinstance(result.get("nearest_source"), str):
            result["nearest_source"] = decode_u32le_base64(result["nearest_source"], use_numpy)
    return result


def decode_matrix_result(
    result: dict[str, Any], use_numpy: Optional[bool] = None
) -> dict[str, Any]:
    """Decodes a ``geodesic.matrix`` result in ``"f64le-base64"`` in place (``distances``
    becomes a sources x targets float64 array, ``inf`` where unreachable) and returns it.
    JSON-encoded results are returned unchanged."""
    if result.get("encoding") != "f64le-base64" or not isinstance(result.get("distances"), str):
        return result
    rows, cols = int(result.get("sources", 0)), int(result.get("targets", 0))
    values = decode_f64le_base64(result["distances"], use_numpy)
    if len(values) != rows * cols:
        raise ValueError(f"distances hold {len(values)} values, not {rows} x {cols}")
    if _use_numpy(use_numpy):
        result["distances"] = values.reshape(rows, cols)
    else:
        result["distances"] = [values[i * cols : (i + 1) * cols] for i in range(rows)]
    return result
