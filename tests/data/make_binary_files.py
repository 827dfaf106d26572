#!/usr/bin/env python3
"""Writes the PLY and STL test files of tests/data (run once; the output is committed).

octahedron.ply / octahedron_binary.ply: the same octahedron as ascii and binary little-endian
PLY; its coordinates (0, +-1) are exact in float and double, so both must load identically.
tetrahedron_ascii.stl / tetrahedron_binary.stl: a tetrahedron as STL, every facet repeating its
corners (12 corners, 4 distinct points); coordinates such as 0.1 are stored as float32 in both.
degenerate_facet.stl: facet 1 has two identical corners.
nan_corner.stl: binary, corner 2 of facet 1 has a NaN coordinate.
quad_binary.ply: binary PLY whose face 1 is a quad.
cut_binary.ply: octahedron_binary.ply cut 26 bytes short, inside its face lists: long enough for
the smallest records its header allows.
comment_before_end_header.ply: octahedron_binary.ply with its comment moved to the line before
end_header, which makes OpenMesh 9's reader read the data one byte off.
strips.ply / strips_binary.ply: a 3 x 3 grid of vertices as triangle strips (element tristrips,
as Stanford's scans store them), three records: a strip with three degenerate triangles in a row
(an odd number, so that numbering the triangles kept instead of the strip's would turn the next
one round), a one-triangle record (so that not restarting the count at each record would turn
the third record round), and two strips split by -1. Both unroll to the same 8 triangles.
"""
import struct

OCTAHEDRON_VERTICES = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
OCTAHEDRON_FACES = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4),
                    (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]


def ply_header(fmt, vertices, faces, vertex_type="float", face_element="face",
               length_type="uchar"):
    return (f"ply\nformat {fmt} 1.0\ncomment geoprox test data\n"
            f"element vertex {vertices}\nproperty {vertex_type} x\nproperty {vertex_type} y\n"
            f"property {vertex_type} z\nelement {face_element} {faces}\n"
            f"property list {length_type} int vertex_indices\nend_header\n")


def write_octahedra():
    with open("octahedron.ply", "w") as out:
        out.write(ply_header("ascii", len(OCTAHEDRON_VERTICES), len(OCTAHEDRON_FACES)))
        for v in OCTAHEDRON_VERTICES:
            out.write("%g %g %g\n" % v)
        for f in OCTAHEDRON_FACES:
            out.write("3 %d %d %d\n" % f)
    with open("octahedron_binary.ply", "wb") as out:
        out.write(ply_header("binary_little_endian", len(OCTAHEDRON_VERTICES),
                             len(OCTAHEDRON_FACES)).encode())
        for v in OCTAHEDRON_VERTICES:
            out.write(struct.pack("<3f", *v))
        for f in OCTAHEDRON_FACES:
            out.write(struct.pack("<B3i", 3, *f))


def write_cut_ply():
    with open("octahedron_binary.ply", "rb") as whole:
        data = whole.read()
    with open("cut_binary.ply", "wb") as out:
        out.write(data[:-26])
    header, body = data.split(b"end_header\n", 1)
    header = header.replace(b"comment geoprox test data\n", b"")
    with open("comment_before_end_header.ply", "wb") as out:
        out.write(header + b"comment geoprox test data\nend_header\n" + body)


def write_quad_ply():
    vertices = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0)]
    with open("quad_binary.ply", "wb") as out:
        out.write(ply_header("binary_little_endian", len(vertices), 2).encode())
        for v in vertices:
            out.write(struct.pack("<3f", *v))
        out.write(struct.pack("<B3i", 3, 1, 4, 2))
        out.write(struct.pack("<B4i", 4, 0, 1, 2, 3))


GRID_VERTICES = [(x, y, 0) for y in range(3) for x in range(3)]
GRID_STRIPS = [[0, 3, 1, 4, 4, 4, 2, 5], [1, 4, 2], [3, 6, 4, 7, -1, 4, 7, 5, 8]]


def strips_header(fmt):
    return ply_header(fmt, len(GRID_VERTICES), len(GRID_STRIPS), face_element="tristrips",
                      length_type="int")


def write_strips():
    with open("strips.ply", "w") as out:
        out.write(strips_header("ascii"))
        for v in GRID_VERTICES:
            out.write("%g %g %g\n" % v)
        for strip in GRID_STRIPS:
            out.write(" ".join(str(i) for i in [len(strip)] + strip) + "\n")
    with open("strips_binary.ply", "wb") as out:
        out.write(strips_header("binary_little_endian").encode())
        for v in GRID_VERTICES:
            out.write(struct.pack("<3f", *v))
        for strip in GRID_STRIPS:
            out.write(struct.pack("<%di" % (len(strip) + 1), len(strip), *strip))


TETRA_POINTS = [(0.1, 0.0, 0.0), (1.0, 0.1, 0.0), (0.0, 1.0, 0.1), (0.0, 0.0, 1.0)]
TETRA_FACETS = [(0, 2, 1), (0, 1, 3), (1, 2, 3), (2, 0, 3)]


def write_ascii_stl(path, facets):
    with open(path, "w") as out:
        out.write("solid geoprox\n")
        for corners in facets:
            out.write("  facet normal 0 0 0\n    outer loop\n")
            for p in corners:
                out.write("      vertex %.9g %.9g %.9g\n" % p)
            out.write("    endloop\n  endfacet\n")
        out.write("endsolid geoprox\n")


def write_binary_stl(path, facets):
    with open(path, "wb") as out:
        out.write(b"geoprox test data".ljust(80, b" "))
        out.write(struct.pack("<I", len(facets)))
        for corners in facets:
            out.write(struct.pack("<3f", 0, 0, 0))
            for p in corners:
                out.write(struct.pack("<3f", *p))
            out.write(b"\0\0")


def write_stls():
    tetra = [[TETRA_POINTS[i] for i in f] for f in TETRA_FACETS]
    write_ascii_stl("tetrahedron_ascii.stl", tetra)
    write_binary_stl("tetrahedron_binary.stl", tetra)
    degenerate = [tetra[0], [TETRA_POINTS[0], TETRA_POINTS[1], TETRA_POINTS[1]], tetra[2]]
    write_ascii_stl("degenerate_facet.stl", degenerate)
    nan_corner = [tetra[0], [TETRA_POINTS[0], TETRA_POINTS[1], (float("nan"), 0.0, 1.0)]]
    write_binary_stl("nan_corner.stl", nan_corner)


if __name__ == "__main__":
    write_octahedra()
    write_cut_ply()
    write_quad_ply()
    write_strips()
    write_stls()
