"""Offline tests of the geoprox client: point helpers, field decoding, errors, requests."""

from __future__ import annotations

import array
import base64
import math
import struct
import unittest
from typing import Any

import geoprox
from geoprox import GeoproxConnectionError, GeoproxTimeoutError, Reason, ServerError
from geoprox.errors import error_from_reply


class PointTest(unittest.TestCase):
    def test_helpers(self) -> None:
        self.assertEqual(geoprox.vertex(12), {"vertex": 12})
        self.assertEqual(geoprox.edge(7, 0.25), {"edge": 7, "t": 0.25})
        self.assertEqual(geoprox.face(5, 0.2, 0.3, 0.5), {"face": 5, "bary": [0.2, 0.3, 0.5]})
        self.assertEqual(geoprox.sample(3), {"sample": 3})
        self.assertEqual(geoprox.position(1, -2, 3.5), {"position": [1.0, -2.0, 3.5]})
        bad_calls = [
            lambda: geoprox.vertex(-1),
            lambda: geoprox.vertex(1.0),  # type: ignore[arg-type]
            lambda: geoprox.vertex(True),
            lambda: geoprox.edge(1, math.nan),
            lambda: geoprox.position(0, math.inf, 0),
        ]
        for bad in bad_calls:
            with self.assertRaises(ValueError):
                bad()

    def test_parse_and_format(self) -> None:
        cases: dict[str, dict[str, Any]] = {
            "v:12": {"vertex": 12},
            "e:7:0.25": {"edge": 7, "t": 0.25},
            "e:7:2.5e-1": {"edge": 7, "t": 0.25},
            "f:5:0.2:0.3:0.5": {"face": 5, "bary": [0.2, 0.3, 0.5]},
            "s:3": {"sample": 3},
            "p:0.37,-0.29,.19": {"position": [0.37, -0.29, 0.19]},
        }
        for text, obj in cases.items():
            with self.subTest(text=text):
                self.assertEqual(geoprox.parse_point(text), obj)
                self.assertEqual(geoprox.parse_point(geoprox.format_point(obj)), obj)
        self.assertEqual(geoprox.format_point("v:1"), "v:1")
        for bad in [
            "",
            "v:",
            "v:1.5",
            "v:-1",
            "v:+1",
            "x:1",
            "e:1",
            "f:1:0:1",
            "p:1,2",
            "v:1 ",
            "e:1:+0.5",
            "e:1:inf",
        ]:
            with self.subTest(text=bad), self.assertRaises(ValueError):
                geoprox.parse_point(bad)

    def test_as_point(self) -> None:
        self.assertEqual(geoprox.as_point("v:1"), "v:1")
        self.assertEqual(geoprox.as_point(geoprox.vertex(1)), {"vertex": 1})
        with self.assertRaises(TypeError):
            geoprox.as_point(3)  # type: ignore[arg-type]


class EncodingTest(unittest.TestCase):
    DOC_EXAMPLE = "AAAAAAAAgD8AAMA/AACAPw=="  # docs/protocol.md: the floats 0, 1, 1.5, 1

    def test_f32(self) -> None:
        plain = geoprox.decode_f32le_base64(self.DOC_EXAMPLE, use_numpy=False)
        self.assertIsInstance(plain, array.array)
        self.assertEqual(list(plain), [0.0, 1.0, 1.5, 1.0])
        default = geoprox.decode_f32le_base64(self.DOC_EXAMPLE)
        self.assertEqual([float(x) for x in default], [0.0, 1.0, 1.5, 1.0])
        if geoprox.HAVE_NUMPY:
            import numpy

            self.assertIsInstance(default, numpy.ndarray)
            self.assertEqual(default.dtype, numpy.float32)
        else:
            with self.assertRaises(RuntimeError):
                geoprox.decode_f32le_base64(self.DOC_EXAMPLE, use_numpy=True)
        with_inf = base64.b64encode(struct.pack("<2f", 0.5, math.inf)).decode()
        self.assertEqual(
            list(geoprox.decode_f32le_base64(with_inf, use_numpy=False)), [0.5, math.inf]
        )
        for bad in ["AAAA!", "AAAAAAA="]:  # not base64; 5 bytes are not whole floats
            with self.subTest(text=bad), self.assertRaises(ValueError):
                geoprox.decode_f32le_base64(bad, use_numpy=False)

    def test_u32_and_field_result(self) -> None:
        text = base64.b64encode(struct.pack("<3I", 0, 1, 0xFFFFFFFF)).decode()
        result = {"encoding": "f32le-base64", "distances": self.DOC_EXAMPLE, "nearest_source": text}
        geoprox.decode_field_result(result, use_numpy=False)
        self.assertEqual(list(result["distances"]), [0.0, 1.0, 1.5, 1.0])
        self.assertEqual(list(result["nearest_source"]), [0, 1, geoprox.NOT_REACHED_SOURCE])
        as_json = {"encoding": "json", "distances": [0.0, None]}
        self.assertEqual(geoprox.decode_field_result(dict(as_json)), as_json)


class ErrorTest(unittest.TestCase):
    def test_from_reply(self) -> None:
        error = error_from_reply(
            {
                "code": -32030,
                "message": "queue full",
                "data": {"reason": "Overloaded", "retryable": True, "retry_after_ms": 50},
            }
        )
        self.assertIsInstance(error, ServerError)
        self.assertIsInstance(error, geoprox.GeoproxError)
        self.assertEqual(
            (error.code, error.reason, error.retryable, error.retry_after_ms),
            (-32030, Reason.OVERLOADED, True, 50),
        )
        self.assertTrue(error.is_reason("MeshNotReady", "Overloaded"))
        self.assertFalse(error.is_reason("UnknownMesh"))
        self.assertEqual(str(error), "queue full [Overloaded]")
        odd = error_from_reply("nonsense")
        self.assertEqual(odd.reason, Reason.BAD_REPLY)

    def test_hierarchy(self) -> None:
        self.assertTrue(issubclass(GeoproxConnectionError, ConnectionError))
        self.assertTrue(issubclass(GeoproxConnectionError, geoprox.GeoproxError))
        self.assertTrue(issubclass(GeoproxTimeoutError, TimeoutError))
        self.assertTrue(issubclass(GeoproxTimeoutError, geoprox.GeoproxError))
        self.assertTrue(issubclass(geoprox.GeoproxProtocolError, geoprox.GeoproxError))


class RequestTest(unittest.TestCase):
    def test_builder(self) -> None:
        r = geoprox.request
        self.assertEqual(
            r.distance("spot", "v:0", geoprox.vertex(1), exact=True, timeout_ms=500),
            geoprox.Request(
                "geodesic.distance",
                {
                    "mesh": "spot",
                    "source": "v:0",
                    "target": {"vertex": 1},
                    "exact": True,
                    "timeout_ms": 500,
                },
            ),
        )
        self.assertEqual(
            r.field("spot", ["v:0", "v:1"]).params, {"mesh": "spot", "sources": ["v:0", "v:1"]}
        )
        self.assertEqual(r.mesh_list(), geoprox.Request("mesh.list", {}))
        self.assertEqual(r.admin_reload(token="t").params, {"token": "t"})
        self.assertEqual(
            r.batch([r.health(), ("mesh.info", {"mesh": "a"})]).params,
            {
                "requests": [
                    {"method": "server.health", "params": {}},
                    {"method": "mesh.info", "params": {"mesh": "a"}},
                ]
            },
        )
        with self.assertRaises(TypeError):
            r.batch([42])  # type: ignore[list-item]


if __name__ == "__main__":
    unittest.main()
