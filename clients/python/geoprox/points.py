"""Surface points, as docs/protocol.md ("Points") writes them.

A point is either the object form (a dict such as ``{"vertex": 12}``), built here by
:func:`vertex`, :func:`edge`, :func:`face`, :func:`sample` and :func:`position`, or the
command-line string form (``"v:12"``, ``"e:7:0.25"``, ``"f:5:0.2:0.3:0.5"``, ``"s:3"``,
``"p:0.1,0.2,0.3"``), which the client sends as it is: the server parses it and answers
``BadPoint`` (and friends) for a malformed one. :func:`parse_point` turns a string into the
object form locally, and :func:`format_point` does the reverse (results always carry points in
the object form).
"""

from __future__ import annotations

import math
import re
from typing import Any, Mapping, Union

__all__ = [
    "Point",
    "vertex",
    "edge",
    "face",
    "sample",
    "position",
    "parse_point",
    "format_point",
    "as_point",
]

#: A point argument: the object form (a mapping) or the command-line string form.
Point = Union[str, Mapping[str, Any]]

# C decimal syntax without a leading '+', as the protocol's string form requires.
_NUMBER = r"-?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_ID = r"\d+"
_FORMS = {
    "v": re.compile(rf"v:({_ID})"),
    "e": re.compile(rf"e:({_ID}):({_NUMBER})"),
    "f": re.compile(rf"f:({_ID}):({_NUMBER}):({_NUMBER}):({_NUMBER})"),
    "s": re.compile(rf"s:({_ID})"),
    "p": re.compile(rf"p:({_NUMBER}),({_NUMBER}),({_NUMBER})"),
}


def _check_id(value: int, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ValueError(f"{what} id must be a non-negative integer, not {value!r}")
    return value


def _check_number(value: float, what: str) -> float:
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"{what} must be finite, not {value!r}")
    return number


def vertex(i: int) -> dict[str, Any]:
    """Vertex ``i`` (0-based file order): ``{"vertex": i}``."""
    return {"vertex": _check_id(i, "vertex")}


def edge(e: int, t: float) -> dict[str, Any]:
    """The point at ``t`` in [0, 1] along edge ``e``, from its origin to its target."""
    return {"edge": _check_id(e, "edge"), "t": _check_number(t, "edge parameter t")}


def face(f: int, b0: float, b1: float, b2: float) -> dict[str, Any]:
    """The point of face ``f`` with barycentric coordinates ``b0, b1, b2`` (summing to 1) in
    the order of the face's vertices in the file."""
    bary = [_check_number(b, "barycentric coordinate") for b in (b0, b1, b2)]
    return {"face": _check_id(f, "face"), "bary": bary}


def sample(i: int) -> dict[str, Any]:
    """Sample (node) ``i`` of the mesh's proximity graph."""
    return {"sample": _check_id(i, "sample")}


def position(x: float, y: float, z: float) -> dict[str, Any]:
    """A point in space; the server snaps it to the nearest surface point."""
    return {"position": [_check_number(c, "coordinate") for c in (x, y, z)]}


def parse_point(text: str) -> dict[str, Any]:
    """The object form of a command-line point string (``"f:5:0.2:0.3:0.5"``...).

    Raises ValueError for a string that is not one of the forms. Ranges (``t`` in [0, 1],
    barycentrics summing to 1, ids against the mesh) are left to the server.
    """
    pattern = _FORMS.get(text[:1]) if isinstance(text, str) else None
    match = pattern.fullmatch(text) if pattern else None
    if match is None:
        raise ValueError(f"{text!r} is not a point (v:ID, e:ID:T, f:ID:B0:B1:B2, s:ID or p:X,Y,Z)")
    groups = match.groups()
    kind = text[0]
    if kind == "v":
        return vertex(int(groups[0]))
    if kind == "e":
        return edge(int(groups[0]), float(groups[1]))
    if kind == "f":
        return face(int(groups[0]), *(float(g) for g in groups[1:]))
    if kind == "s":
        return sample(int(groups[0]))
    return position(*(float(g) for g in groups))


def format_point(point: Point) -> str:
    """The command-line string form of a point (strings are returned unchanged)."""
    if isinstance(point, str):
        return point
    if "vertex" in point:
        return f"v:{point['vertex']}"
    if "edge" in point:
        return f"e:{point['edge']}:{point['t']!r}"
    if "face" in point:
        return f"f:{point['face']}:" + ":".join(repr(float(b)) for b in point["bary"])
    if "sample" in point:
        return f"s:{point['sample']}"
    if "position" in point:
        return "p:" + ",".join(repr(float(c)) for c in point["position"])
    raise ValueError(f"not a point: {point!r}")


def as_point(point: Point) -> Point:
    """Checks the type of a point argument and returns what goes on the wire.

    Strings and mappings are passed as they are (a mapping is copied into a plain dict), and a
    :class:`~geoprox.arrays.PointSet` of one point is that point. Raises TypeError for anything
    else, so ``distance(mesh, 3, 4)`` fails loudly instead of guessing whether 3 is a vertex or
    a sample, and an ndarray must say what it holds (``geoprox.vertices(ids)``...).
    """
    if isinstance(point, str):
        return point
    if isinstance(point, Mapping):
        return dict(point)
    from .arrays import PointSet

    if isinstance(point, PointSet):
        if len(point) != 1:
            raise TypeError(f"one point is expected here, not a PointSet of {len(point)}")
        return point[0]
    raise TypeError(
        f"a point is a string such as 'v:12' or a dict such as geoprox.vertex(12), "
        f"not {type(point).__name__}"
    )
