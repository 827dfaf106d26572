"""numpy in and out (geoprox.arrays) against a real geoproxd, over TCP and over HTTP.

Needs numpy: ctest runs it as ``python_client_numpy`` with an interpreter that has it (Debian's
/usr/bin/python3 with python3-numpy); without numpy the module is skipped, so the stdlib-only
``python_client`` run of the whole directory passes over it. The daemon (GEOPROXD) serves
data/meshes/spot.obj and a mesh of two components (a tetrahedron and, apart, a square), so that
some answers are unreachable.

Checked: arrays equal the JSON answers bit for bit (float64), NaN where unreachable, shapes and
dtypes, a path's xyz is the barycentric combination of its face's corners, and points built
from arrays give the same answers as the equivalent strings.
"""

from __future__ import annotations

import math
import os
import shutil
import struct
import tempfile
import unittest
from pathlib import Path
from typing import Any, Optional

import geoprox

if not geoprox.HAVE_NUMPY:
    raise unittest.SkipTest("numpy cannot be imported: the numpy tests need it")

import numpy as np  # noqa: E402

from test_client import (  # noqa: E402
    SPOT_FACES,
    SPOT_OBJ,
    SPOT_VERTICES,
    TWO_COMPONENTS_OBJ,
    Daemon,
)

ROOT: Optional[tempfile.TemporaryDirectory] = None
DAEMON: Optional[Daemon] = None


def setUpModule() -> None:
    global ROOT, DAEMON
    binary = os.environ.get("GEOPROXD")
    if not binary or not os.access(binary, os.X_OK):
        raise RuntimeError("GEOPROXD must name the geoproxd binary (ctest sets it)")
    os.environ.pop("GEOPROX_TOKEN", None)
    ROOT = tempfile.TemporaryDirectory(prefix="geoprox-numpy-test-")
    root = Path(ROOT.name)
    (root / "data" / "meshes").mkdir(parents=True)
    (root / "graphs").mkdir()
    shutil.copy(SPOT_OBJ, root / "data" / "meshes" / "spot.obj")
    (root / "data" / "meshes" / "two.obj").write_text(TWO_COMPONENTS_OBJ)
    DAEMON = Daemon(
        binary,
        root,
        "numpy",
        meshes=[
            {"id": "spot", "mesh": "meshes/spot.obj", "samples": 400, "neighbors": 12},
            {"id": "two", "mesh": "meshes/two.obj", "samples": 4, "neighbors": 1},
        ],
    )
    with DAEMON.client() as client:
        client.wait_ready(timeout=300)


def tearDownModule() -> None:
    if DAEMON is not None:
        status = DAEMON.stop()
        if status != 0:
            print(f"geoproxd exited with status {status}:\n{DAEMON.output()}")
    if ROOT is not None:
        ROOT.cleanup()


def spot_geometry() -> tuple[Any, Any]:
    """spot.obj's vertex positions (n x 3) and triangles (m x 3, 0-based), read here."""
    positions, triangles = [], []
    for line in SPOT_OBJ.read_text().splitlines():
        if line.startswith("v "):
            positions.append([float(x) for x in line.split()[1:4]])
        elif line.startswith("f "):
            triangles.append([int(c.split("/")[0]) - 1 for c in line.split()[1:4]])
    return np.array(positions, dtype=np.float64), np.array(triangles, dtype=np.int64)


def bits(values: Any) -> Any:
    """The IEEE-754 bits of a float64 array (NaN compares equal to NaN this way)."""
    return np.ascontiguousarray(values, dtype=np.float64).view(np.uint64)


def json_field(values: list) -> Any:
    return np.array([math.nan if d is None else d for d in values], dtype=np.float64)


class ArraysTest(unittest.TestCase):
    transport = "tcp"

    def setUp(self) -> None:
        assert DAEMON is not None
        self.client = DAEMON.client(self.transport, timeout=120.0)
        self.rng = np.random.default_rng(42)

    def tearDown(self) -> None:
        self.client.close()

    def random_faces(self, n: int) -> tuple[Any, Any]:
        f = self.rng.integers(0, SPOT_FACES, size=n)
        b = self.rng.random((n, 3)) + 0.05
        return f, b / b.sum(axis=1, keepdims=True)

    def assertBitsEqual(self, got: Any, want: Any) -> None:
        self.assertEqual(got.shape, want.shape)
        np.testing.assert_array_equal(bits(got), bits(want))

    def test_matrix_of_face_points_equals_the_json_matrix_bit_for_bit(self) -> None:
        f, b = self.random_faces(7)
        sources = geoprox.faces(f, b)
        targets = geoprox.vertices(np.arange(0, SPOT_VERTICES, 300)) + geoprox.faces(f[:3], b[:3])
        as_json = self.client.matrix("spot", sources, targets)
        as_array = self.client.matrix("spot", sources, targets, as_array=True)
        want = np.array(as_json["distances"], dtype=np.float64)
        got = as_array["distances"]
        self.assertEqual(got.dtype, np.float64)
        self.assertEqual(got.shape, (7, len(targets)))
        self.assertBitsEqual(got, want)
        self.assertFalse(np.isnan(got).any())
        self.assertEqual(as_array["unreachable"], 0)
        self.assertEqual((as_array["sources"], as_array["targets"]), (7, len(targets)))
        self.assertEqual(as_array["mesh_version"], as_json["mesh_version"])
        # The same points as strings written by hand give the very same doubles.
        strings = [
            f"f:{fi}:{b0!r}:{b1!r}:{b2!r}" for fi, (b0, b1, b2) in zip(f.tolist(), b.tolist())
        ]
        self.assertEqual(list(sources), strings)
        by_strings = self.client.matrix("spot", strings, list(targets))
        self.assertEqual(by_strings["distances"], as_json["distances"])

    def test_unreachable_is_nan(self) -> None:
        # Vertices 0-3: the tetrahedron; 4-7: the square, apart from it.
        ids = np.array([0, 2, 4, 7])
        as_array = self.client.matrix("two", geoprox.vertices(ids), geoprox.vertices(ids),
                                      as_array=True)["distances"]
        as_json = self.client.matrix("two", geoprox.vertices(ids), geoprox.vertices(ids))
        same = np.array([[i < 4 and k < 4 or i >= 4 and k >= 4 for k in ids] for i in ids])
        np.testing.assert_array_equal(np.isnan(as_array), ~same)
        self.assertEqual(as_json["unreachable"], int((~same).sum()))
        self.assertBitsEqual(as_array, json_field(sum(as_json["distances"], [])).reshape(4, 4))
        field = self.client.field("two", geoprox.vertices([0]), as_array=True)
        self.assertEqual(field["distances"].shape, (8,))
        np.testing.assert_array_equal(np.isnan(field["distances"]), np.arange(8) >= 4)
        self.assertEqual(field["reached"], 4)

    def test_field_equals_the_json_field_bit_for_bit(self) -> None:
        for cutoff in (None, 0.3):
            as_json = self.client.field("spot", "f:100:0.2:0.3:0.5", cutoff=cutoff)
            as_array = self.client.field(
                "spot", geoprox.faces([100], [[0.2, 0.3, 0.5]]), cutoff=cutoff, as_array=True
            )
            got = as_array["distances"]
            self.assertEqual((got.dtype, got.shape), (np.float64, (SPOT_VERTICES,)))
            self.assertBitsEqual(got, json_field(as_json["distances"]))
            self.assertEqual(as_array["reached"], as_json["reached"])
            self.assertEqual(int(np.isfinite(got).sum()), as_json["reached"])
            if cutoff is not None:
                self.assertGreater(int(np.isnan(got).sum()), 0)  # beyond the cutoff
            self.assertNotIn("nearest_source", as_array)

    def test_field_of_several_sources_has_nearest_source(self) -> None:
        sources = geoprox.vertices(np.array([0, 1500], dtype=np.uint32))
        as_json = self.client.field("spot", sources, cutoff=0.25)
        as_array = self.client.field("spot", sources, cutoff=0.25, as_array=True)
        self.assertBitsEqual(as_array["distances"], json_field(as_json["distances"]))
        nearest = as_array["nearest_source"]
        self.assertEqual((nearest.dtype, nearest.shape), (np.uint32, (SPOT_VERTICES,)))
        want = [geoprox.NOT_REACHED_SOURCE if k is None else k for k in as_json["nearest_source"]]
        np.testing.assert_array_equal(nearest, np.array(want, dtype=np.uint32))
        self.assertTrue((nearest == geoprox.NOT_REACHED_SOURCE).any())
        np.testing.assert_array_equal(nearest == geoprox.NOT_REACHED_SOURCE,
                                      np.isnan(as_array["distances"]))

    def test_path_arrays_are_consistent(self) -> None:
        positions, triangles = spot_geometry()
        self.assertEqual(triangles.shape, (SPOT_FACES, 3))
        as_json = self.client.path("spot", "v:0", "f:4000:0.2:0.3:0.5")
        target = geoprox.faces([4000], [[0.2, 0.3, 0.5]])
        path = self.client.path("spot", geoprox.vertices([0]), target, as_array=True)
        n = len(as_json["points"])
        self.assertGreater(n, 2)
        self.assertEqual((path["faces"].dtype, path["faces"].shape), (np.int64, (n,)))
        self.assertEqual((path["bary"].dtype, path["bary"].shape), (np.float64, (n, 3)))
        self.assertEqual((path["xyz"].dtype, path["xyz"].shape), (np.float64, (n, 3)))
        self.assertNotIn("points", path)
        self.assertEqual(path["distance"], as_json["distance"])
        self.assertEqual(path["faces"].tolist(), [p["face"] for p in as_json["points"]])
        self.assertBitsEqual(path["bary"], np.array([p["bary"] for p in as_json["points"]]))
        self.assertBitsEqual(path["xyz"], np.array([p["position"] for p in as_json["points"]]))
        corners = positions[triangles[path["faces"]]]  # n x 3 corners x 3 coordinates
        combined = np.einsum("nk,nkc->nc", path["bary"], corners)
        scale = np.abs(positions).max()
        np.testing.assert_allclose(path["xyz"], combined, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(path["bary"].sum(axis=1), 1.0, rtol=0, atol=1e-12)

    def test_positions_snap_like_the_equivalent_strings(self) -> None:
        xyz = np.array([[0.37, -0.29, 0.19], [0.1, 0.2, 0.3]]) + 1e-17 * np.pi
        points = geoprox.positions(xyz)
        self.assertEqual(points[0], "p:" + ",".join(repr(float(c)) for c in xyz[0]))
        # repr writes the shortest text that reads back as the same double.
        self.assertTrue(all(float(t) == c for t, c in zip(points[0][2:].split(","), xyz[0])))
        by_array = self.client.distance("spot", points[0:1], points[1:2])
        by_string = self.client.distance("spot", points[0], points[1])
        self.assertEqual(by_array, by_string)

    def test_batch_and_pipeline_entries_come_as_arrays(self) -> None:
        f, b = self.random_faces(3)
        whole = self.client.matrix("spot", geoprox.faces(f, b), geoprox.faces(f, b), as_array=True)
        [in_batch, plain] = self.client.batch(
            [
                geoprox.request.matrix("spot", geoprox.faces(f, b), geoprox.faces(f, b),
                                       as_array=True),
                geoprox.request.matrix("spot", geoprox.faces(f, b), geoprox.faces(f, b)),
            ]
        )
        self.assertBitsEqual(in_batch["distances"], whole["distances"])
        self.assertIsInstance(plain["distances"], list)
        with self.client.pipeline() as pipe:
            pending = pipe.matrix("spot", geoprox.faces(f, b), geoprox.faces(f, b), as_array=True)
            path = pipe.path("spot", "v:0", "v:9", as_array=True)
        self.assertBitsEqual(pending.result()["distances"], whole["distances"])
        self.assertEqual(path.result()["faces"].dtype, np.int64)

    def test_client_wide_arrays_option(self) -> None:
        assert DAEMON is not None
        with DAEMON.client(self.transport, arrays=True) as client:
            got = client.matrix("spot", ["v:0"], ["v:1", "v:2"])["distances"]
            self.assertEqual(got.shape, (1, 2))
            listed = client.matrix("spot", ["v:0"], ["v:1", "v:2"], as_array=False)["distances"]
            self.assertBitsEqual(got, np.array(listed))
        # use_numpy=False only concerns the decoding of base64 fields; as_array still gives arrays.
        with DAEMON.client(self.transport, use_numpy=False) as client:
            again = client.matrix("spot", ["v:0"], ["v:1", "v:2"], as_array=True)["distances"]
            self.assertBitsEqual(again, got)
            field = client.field("spot", "v:0", as_array=True)["distances"]
            self.assertEqual((field.dtype, field.shape), (np.float64, (SPOT_VERTICES,)))

    def test_bad_arrays_are_refused_with_clear_errors(self) -> None:
        with self.assertRaisesRegex(TypeError, "ids must be integers, not float64"):
            geoprox.vertices(np.array([1.0, 2.0]))
        with self.assertRaisesRegex(ValueError, "ids must be >= 0, not -3 at index 1"):
            geoprox.vertices([1, -3])
        with self.assertRaisesRegex(ValueError, r"ids must be a 1-D array, not of shape \(2, 2\)"):
            geoprox.vertices(np.zeros((2, 2), dtype=int))
        with self.assertRaisesRegex(ValueError,
                                    r"bary must be an \(n, 3\) array, not of shape \(2, 2\)"):
            geoprox.faces([1, 2], np.zeros((2, 2)))
        with self.assertRaisesRegex(ValueError, r"bary\[1, 2\] is nan; every value must be finite"):
            geoprox.faces([1, 2], [[1, 0, 0], [0.5, 0.5, math.nan]])
        with self.assertRaisesRegex(ValueError, "2 face ids but 1 barycentric rows"):
            geoprox.faces([1, 2], [[1, 0, 0]])
        with self.assertRaisesRegex(ValueError, r"xyz\[0, 0\] is inf"):
            geoprox.positions([[math.inf, 0, 0]])
        with self.assertRaisesRegex(TypeError, "not a PointSet of 2"):
            self.client.distance("spot", geoprox.vertices([0, 1]), "v:2")
        with self.assertRaisesRegex(TypeError, "a point is a string"):
            self.client.distance("spot", np.array([0]), "v:2")  # an ndarray must say what it is
        with self.assertRaisesRegex(ValueError, "as_array takes the field as float64"):
            self.client.field("spot", "v:0", encoding="f32le-base64", as_array=True)
        # The server names a bad face or barycentric in the arrays.
        with self.assertRaises(geoprox.ServerError) as caught:
            self.client.matrix("spot", geoprox.faces([0, SPOT_FACES], [[1, 0, 0]] * 2), ["v:0"],
                               as_array=True)
        self.assertIn("sources[1]", str(caught.exception))


class HttpArraysTest(ArraysTest):
    transport = "http"


class EncodingTest(unittest.TestCase):
    """f64le-base64 decoding, without a daemon."""

    def test_f64_base64_decodes_bit_for_bit(self) -> None:
        import base64

        values = [0.0, -0.0, 0.1, 1 / 3, 5e-324, math.inf]
        text = base64.b64encode(struct.pack("<6d", *values)).decode()
        decoded = geoprox.decode_f64le_base64(text)
        self.assertEqual(decoded.dtype, np.float64)
        np.testing.assert_array_equal(bits(decoded), bits(np.array(values)))
        plain = geoprox.decode_f64le_base64(text, use_numpy=False)
        self.assertEqual(plain.typecode, "d")
        self.assertEqual([struct.pack("<d", v) for v in plain],
                         [struct.pack("<d", v) for v in values])
        with self.assertRaisesRegex(ValueError, "not a whole number of 64-bit values"):
            geoprox.decode_f64le_base64(base64.b64encode(b"1234").decode())
        matrix = geoprox.decode_matrix_result(
            {"encoding": "f64le-base64", "sources": 2, "targets": 3, "distances": text}
        )
        self.assertEqual(matrix["distances"].shape, (2, 3))


if __name__ == "__main__":
    unittest.main()
