"""numpy in and out: point sets built from arrays, and results decoded into arrays.

Points: :func:`vertices`, :func:`faces` and :func:`positions` turn numpy arrays into a
:class:`PointSet`, which every method taking several points accepts (``matrix`` sources and
targets, ``field`` sources) and, when it holds exactly one point, every method taking one
(``distance``, ``path``, ``field`` source). The points travel in the string form of
docs/protocol.md, each float written with ``repr`` (the shortest text that reads back as the
same double), so the daemon computes with the very doubles of the arrays.

Results: with ``as_array=True`` (per call) or ``Client(..., arrays=True)``, fields, matrices
and paths come back as numpy arrays (see :func:`field_arrays`, :func:`matrix_arrays` and
:func:`path_arrays` for the shapes). Fields and matrices travel in the ``"f64le-base64"``
encoding over TCP and as raw float64 over HTTP, so they equal the JSON numbers to the bit.
Unreachable (or beyond the cutoff) is NaN; a vertex no source reached has ``nearest_source``
:data:`~geoprox.encoding.NOT_REACHED_SOURCE` (``0xFFFFFFFF``).

Everything here needs numpy and raises :class:`RuntimeError` when it cannot be imported.
"""

from __future__ import annotations

from typing import Any, Iterator, Sequence, Union, overload

from .encoding import NOT_REACHED_SOURCE, _np, decode_f64le_base64, decode_u32le_base64

__all__ = [
    "PointSet",
    "vertices",
    "faces",
    "positions",
    "require_numpy",
    "field_arrays",
    "matrix_arrays",
    "path_arrays",
]


def require_numpy(what: str) -> Any:
    """numpy, or a RuntimeError saying that ``what`` needs it."""
    if _np is None:
        raise RuntimeError(
            f"{what} needs numpy, which cannot be imported (install it, e.g. apt-get install "
            "python3-numpy); without numpy, pass points as strings such as 'v:12' and read "
            "results as lists"
        )
    return _np


class PointSet(Sequence[str]):
    """Surface points built from arrays: a sequence of point strings (``"v:12"``,
    ``"f:5:0.2:0.3:0.5"``, ``"p:0.1,0.2,0.3"``) in array order.

    Immutable; ``a + b`` concatenates; ``len()``, indexing and slicing as for a list (a slice
    is a PointSet). Build one with :func:`vertices`, :func:`faces` or :func:`positions`."""

    __slots__ = ("_points",)

    def __init__(self, points: Sequence[str]) -> None:
        self._points = tuple(points)

    def __len__(self) -> int:
        return len(self._points)

    @overload
    def __getitem__(self, index: int) -> str: ...

    @overload
    def __getitem__(self, index: slice) -> "PointSet": ...

    def __getitem__(self, index: Union[int, slice]) -> Union[str, "PointSet"]:
        if isinstance(index, slice):
            return PointSet(self._points[index])
        return self._points[index]

    def __iter__(self) -> Iterator[str]:
        return iter(self._points)

    def __add__(self, other: "PointSet") -> "PointSet":
        if not isinstance(other, PointSet):
            return NotImplemented
        return PointSet(self._points + other._points)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, PointSet) and self._points == other._points

    def __hash__(self) -> int:
        return hash(self._points)

    def __repr__(self) -> str:
        shown = ", ".join(self._points[:3]) + (", ..." if len(self._points) > 3 else "")
        return f"<PointSet of {len(self._points)}: {shown}>"


def _ids(values: Any, what: str) -> Any:
    """A 1-D int64 array of non-negative ids from ``values`` (an int array or a sequence)."""
    np = require_numpy(f"geoprox.{what}()")
    array = np.asarray(values)
    if array.ndim == 0:
        array = array.reshape(1)
    if array.ndim != 1:
        raise ValueError(f"{what}: ids must be a 1-D array, not of shape {array.shape}")
    if array.size and array.dtype.kind not in "iu":
        raise TypeError(f"{what}: ids must be integers, not {array.dtype} (no rounding is done)")
    array = array.astype(np.int64, copy=False)
    if array.size and int(array.min()) < 0:
        at = int(np.argmax(array < 0))
        raise ValueError(f"{what}: ids must be >= 0, not {int(array[at])} at index {at}")
    return array


def _rows3(values: Any, what: str, name: str) -> Any:
    """An (n, 3) float64 array of finite numbers from ``values``."""
    np = require_numpy(f"geoprox.{what}()")
    array = np.asarray(values)
    if array.ndim == 1 and array.shape == (3,):
        array = array.reshape(1, 3)
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"{what}: {name} must be an (n, 3) array, not of shape {array.shape}")
    if array.size and array.dtype.kind not in "iuf":
        raise TypeError(f"{what}: {name} must be numbers, not {array.dtype}")
    array = array.astype(np.float64, copy=False)
    bad = ~np.isfinite(array)
    if bad.any():
        row, col = (int(i) for i in np.argwhere(bad)[0])
        raise ValueError(
            f"{what}: {name}[{row}, {col}] is {array[row, col]!r}; every value must be finite"
        )
    return array


def vertices(ids: Any) -> PointSet:
    """Vertices ``ids`` (an int array, 0-based file order) as a :class:`PointSet`."""
    return PointSet([f"v:{i}" for i in _ids(ids, "vertices").tolist()])


def faces(face_ids: Any, bary: Any) -> PointSet:
    """Face points: face ``face_ids[k]`` (an int array of n) at barycentric coordinates
    ``bary[k]`` (an (n, 3) float array, each row summing to 1, in the order of the face's
    vertices in the file). The server checks the sums and the face ids."""
    ids = _ids(face_ids, "faces")
    coords = _rows3(bary, "faces", "bary")
    if len(ids) != len(coords):
        raise ValueError(f"faces: {len(ids)} face ids but {len(coords)} barycentric rows")
    return PointSet(
        [f"f:{f}:{b0!r}:{b1!r}:{b2!r}" for f, (b0, b1, b2) in zip(ids.tolist(), coords.tolist())]
    )


def positions(xyz: Any) -> PointSet:
    """Points in space (an (n, 3) float array) that the server snaps to the nearest surface
    point."""
    rows = _rows3(xyz, "positions", "xyz").tolist()
    return PointSet([f"p:{x!r},{y!r},{z!r}" for x, y, z in rows])


# ---- results ----


def _float64(values: Any, what: str) -> Any:
    """A writable float64 array of ``values``: a base64 string ("f64le-base64"), a JSON list
    (None where not reached) or an array decoded already; ``inf`` and None become NaN."""
    np = require_numpy("as_array")
    if isinstance(values, str):
        out = decode_f64le_base64(values, use_numpy=True)
    elif isinstance(values, list) and values and isinstance(values[0], list):
        out = np.array([[np.nan if d is None else d for d in row] for row in values], np.float64)
    elif isinstance(values, list):
        out = np.array([np.nan if d is None else d for d in values], dtype=np.float64)
    else:
        out = np.array(values, dtype=np.float64)
    if out.dtype != np.float64:
        raise ValueError(f"{what}: not float64")
    out[np.isinf(out)] = np.nan
    return out


def field_arrays(result: dict[str, Any]) -> dict[str, Any]:
    """A ``geodesic.field`` result with arrays, in place: ``distances`` a float64 array of one
    value per vertex (NaN where not reached), ``nearest_source`` (with several sources) a
    uint32 array (``0xFFFFFFFF`` where not reached). ``encoding`` is dropped (the arrays are
    the same whatever the transport carried)."""
    np = require_numpy("as_array")
    encoding = result.pop("encoding", None)
    if encoding == "f32le-base64" or (
        hasattr(result.get("distances"), "dtype") and result["distances"].dtype != np.float64
    ):
        raise ValueError("as_array takes a field in float64, not in float32")
    result["distances"] = _float64(result.get("distances", []), "distances")
    nearest = result.get("nearest_source")
    if isinstance(nearest, str):
        result["nearest_source"] = decode_u32le_base64(nearest, use_numpy=True)
    elif isinstance(nearest, list):
        result["nearest_source"] = np.array(
            [NOT_REACHED_SOURCE if k is None else k for k in nearest], dtype=np.uint32
        )
    elif nearest is not None:
        result["nearest_source"] = np.asarray(nearest, dtype=np.uint32)
    return result


def matrix_arrays(result: dict[str, Any]) -> dict[str, Any]:
    """A ``geodesic.matrix`` result with ``distances`` a sources x targets float64 array, NaN
    where unreachable, in place. ``encoding`` is dropped."""
    result.pop("encoding", None)
    rows, cols = int(result.get("sources", 0)), int(result.get("targets", 0))
    values = _float64(result.get("distances", []), "distances")
    if values.size != rows * cols:
        raise ValueError(f"distances hold {values.size} values, not {rows} x {cols}")
    result["distances"] = values.reshape(rows, cols)
    return result


def path_arrays(result: dict[str, Any]) -> dict[str, Any]:
    """A ``geodesic.path`` result whose ``points`` list is replaced by arrays, in place:
    ``faces`` (int64, n), ``bary`` (float64, n x 3) and ``xyz`` (float64, n x 3), in path
    order."""
    np = require_numpy("as_array")
    points = result.pop("points", [])
    n = len(points)
    result["faces"] = np.array([p["face"] for p in points], dtype=np.int64).reshape(n)
    result["bary"] = np.array([p["bary"] for p in points], dtype=np.float64).reshape(n, 3)
    result["xyz"] = np.array([p["position"] for p in points], dtype=np.float64).reshape(n, 3)
    return result
