#!/usr/bin/env bash
# Result files people can look at (issue 6, section 2), on data/meshes/spot.obj:
#  - `field --out F.ply`: header, counts, geometry and faces as in spot.obj, distances equal to
#    the text output (to float precision), NaN and grey where the text says inf, viridis ends;
#    the file loads back (`geoprox info`).
#  - `path` and `path --out P.obj`: starts at s, ends at t, length equal to the distance.
#  - `render`: a PNG of the requested size, many colours, iso-lines and the red path.
#  - errors: one line, the documented exit code, nothing written.
#  - `remote field --out` and `remote path --out` against a real geoproxd: the same files.
# Usage: bash results_test.sh GEOPROX_BINARY REPO_ROOT
set -euo pipefail
# shellcheck source=lib.sh
source "$(dirname "$0")/lib.sh"
cli_test_setup "$@"

build_spot_graph

# ---------------------------------------------------------------------------------------------
# field --out: PLY against the text output and against spot.obj.
"$geoprox" field "$spot" --graph "$graph" --source v:0 >"$tmp/field.txt" 2>/dev/null ||
  fail "field (text) failed"
"$geoprox" field "$spot" --graph "$graph" --source v:0 --out "$tmp/field.ply" >"$tmp/out" \
  2>"$tmp/err" || fail "field --out failed: $(cat "$tmp/err")"
[ ! -s "$tmp/out" ] || fail "field --out also wrote to stdout"; pass
grep -q "^geoprox: field: wrote $tmp/field.ply (2930 vertices, 5856 faces, distances 0\.\.1\.5[0-9]*, 0 unreachable (nan))\$" \
  "$tmp/err" || fail "field --out message: $(cat "$tmp/err")"; pass
# The same source, cut off at 0.3: 'inf' in the text, NaN and grey in the PLY.
"$geoprox" field "$spot" --graph "$graph" --source v:0 --max-distance 0.3 >"$tmp/cut.txt" 2>/dev/null ||
  fail "field --max-distance failed"
"$geoprox" field "$spot" --graph "$graph" --source v:0 --max-distance 0.3 --out "$tmp/cut.ply" \
  2>/dev/null || fail "field --max-distance --out failed"

cat >"$tmp/result_files.py" <<'PY'
"""read_ply(path) -> (header lines, vertices [(x, y, z, d, r, g, b)], faces [(a, b, c)])."""
import struct


def read_ply(path):
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    nv = int(next(l for l in header if l.startswith("element vertex ")).split()[2])
    nf = int(next(l for l in header if l.startswith("element face ")).split()[2])
    body = data[end:]
    assert len(body) == nv * 19 + nf * 13, (len(body), nv, nf)
    vertices = [struct.unpack_from("<4f3B", body, 19 * i) for i in range(nv)]
    faces = []
    for i in range(nf):
        count, a, b, c = struct.unpack_from("<B3i", body, 19 * nv + 13 * i)
        assert count == 3, count
        faces.append((a, b, c))
    return header, vertices, faces


def read_obj(path):
    """(vertices [(x, y, z)], faces [(a, b, c)] 0-based, line index lists 1-based)."""
    vertices, faces, lines = [], [], []
    for line in open(path):
        fields = line.split()
        if not fields:
            continue
        if fields[0] == "v":
            vertices.append(tuple(float(x) for x in fields[1:4]))
        elif fields[0] == "f":
            faces.append(tuple(int(x.split("/")[0]) - 1 for x in fields[1:]))
        elif fields[0] == "l":
            lines.append([int(x) for x in fields[1:]])
    return vertices, faces, lines
PY

python3 - "$tmp" "$spot" <<'PY' || fail "field PLY does not match the text output or the mesh"
import math, struct, sys
sys.path.insert(0, sys.argv[1])
from result_files import read_ply, read_obj
tmp, spot = sys.argv[1], sys.argv[2]
header, vertices, faces = read_ply(f"{tmp}/field.ply")
expected = ["ply", "format binary_little_endian 1.0"]
assert header[:2] == expected, header
props = [l for l in header if not l.startswith("comment")]
assert props[2:] == [
    "element vertex 2930", "property float x", "property float y", "property float z",
    "property float distance", "property uchar red", "property uchar green", "property uchar blue",
    "element face 5856", "property list uchar int vertex_indices", "end_header"], props
mesh_vertices, mesh_faces, _ = read_obj(spot)
f32 = lambda x: struct.unpack("<f", struct.pack("<f", x))[0]
assert len(vertices) == len(mesh_vertices) == 2930
for v, m in zip(vertices, mesh_vertices):
    assert v[:3] == tuple(f32(c) for c in m), (v, m)
assert faces == [tuple(f) for f in mesh_faces], "faces differ from spot.obj"
text = [float(l) for l in open(f"{tmp}/field.txt")]
assert len(text) == 2930
for v, d in zip(vertices, text):
    assert abs(v[3] - d) <= 6e-8 * d, (v[3], d)
top = max(text)
assert any(f"viridis over [0, {top!r}]" in l for l in header) or \
    any(f"viridis over [0, {top:.17g}]" in l for l in header), [l for l in header if "viridis" in l]
# Colour map ends: the source vertex is viridis(0), the farthest vertex viridis(1).
assert vertices[0][4:] == (68, 1, 84), vertices[0]
assert vertices[text.index(top)][4:] == (253, 231, 37), vertices[text.index(top)]
# Colours darken towards the source: mean green of the nearest tenth below the farthest tenth.
order = sorted(range(2930), key=lambda i: text[i])
near = sum(vertices[i][5] for i in order[:293]) / 293
far = sum(vertices[i][5] for i in order[-293:]) / 293
assert near + 50 < far, (near, far)

# Cut off at 0.3: NaN and grey exactly where the text says inf, the rest as before.
_, cut, _ = read_ply(f"{tmp}/cut.ply")
cut_text = [l.strip() for l in open(f"{tmp}/cut.txt")]
unreached = [i for i, t in enumerate(cut_text) if t == "inf"]
assert 0 < len(unreached) < 2930, len(unreached)
for i, (v, t) in enumerate(zip(cut, cut_text)):
    if t == "inf":
        assert math.isnan(v[3]) and v[4:] == (128, 128, 128), (i, v)
    else:
        assert abs(v[3] - float(t)) <= 6e-8 * float(t) and v[4:] != (128, 128, 128), (i, v, t)
PY
pass
# Unreachable for real: two disjoint tetrahedra, the field from the first.
cat >"$tmp/two.obj" <<'OBJ'
v 0 0 0
v 1 0 0
v 0 1 0
v 0 0 1
v 3 0 0
v 4 0 0
v 3 1 0
v 3 0 1
f 1 3 2
f 1 2 4
f 1 4 3
f 2 3 4
f 5 7 6
f 5 6 8
f 5 8 7
f 6 7 8
OBJ
"$geoprox" build "$tmp/two.obj" -o "$tmp/two.geoprox" --samples 4 --neighbors 2 -q >/dev/null 2>&1 ||
  fail "build of two tetrahedra failed"
"$geoprox" field "$tmp/two.obj" --graph "$tmp/two.geoprox" --source v:0 --out "$tmp/two.ply" \
  2>"$tmp/err" || fail "field --out on two components: $(cat "$tmp/err")"
grep -q "(8 vertices, 8 faces, distances 0\.\.1, 4 unreachable (nan))\$" "$tmp/err" ||
  fail "two components: $(cat "$tmp/err")"; pass
python3 - "$tmp" <<'PY2' || fail "unreachable vertices are not NaN and grey"
import math, sys
sys.path.insert(0, sys.argv[1])
from result_files import read_ply
_, vertices, _ = read_ply(f"{sys.argv[1]}/two.ply")
assert vertices[0][3:] == (0.0, 68, 1, 84), vertices[0]
for v in vertices[1:4]:
    assert abs(v[3] - 1) < 1e-6 and v[4:] == (253, 231, 37), v
for v in vertices[4:]:
    assert math.isnan(v[3]) and v[4:] == (128, 128, 128), v
PY2
pass

"$geoprox" info "$tmp/field.ply" >"$tmp/info" 2>&1 || fail "geoprox info cannot load the PLY: $(cat "$tmp/info")"
grep -q '^ *vertices: 2930$' "$tmp/info" && grep -q '^ *faces: 5856$' "$tmp/info" ||
  fail "the PLY loads back as another mesh: $(cat "$tmp/info")"; pass

# ---------------------------------------------------------------------------------------------
# path: text and OBJ; from s to t, length equal to the distance.
source=v:0
target=f:100:0.2:0.3:0.5
"$geoprox" path "$spot" --graph "$graph" --source "$source" --target "$target" >"$tmp/path.txt" \
  2>"$tmp/path.err" || fail "path failed: $(cat "$tmp/path.err")"
"$geoprox" path "$spot" --graph "$graph" --source "$source" --target "$target" --out "$tmp/path.obj" \
  >"$tmp/out" 2>"$tmp/obj.err" || fail "path --out failed: $(cat "$tmp/obj.err")"
[ ! -s "$tmp/out" ] || fail "path --out also wrote to stdout"; pass
echo "$source $target" | "$geoprox" distance "$spot" --graph "$graph" --pairs - >"$tmp/distance" \
  2>/dev/null || fail "distance failed"
distance=$(cat "$tmp/distance")
grep -qx "geoprox: path: distance $distance, [0-9]* points, exact \(yes\|no\)" "$tmp/path.err" ||
  fail "path does not report the distance $distance: $(cat "$tmp/path.err")"; pass
grep -q "^geoprox: path: wrote $tmp/path.obj (distance $distance, " "$tmp/obj.err" ||
  fail "path --out message: $(cat "$tmp/obj.err")"; pass
python3 - "$tmp" "$spot" "$distance" <<'PY' || fail "path OBJ is not the path from s to t"
import math, sys
sys.path.insert(0, sys.argv[1])
from result_files import read_obj
tmp, spot, distance = sys.argv[1], sys.argv[2], float(sys.argv[3])
mesh_vertices, mesh_faces, _ = read_obj(spot)
points, faces, lines = read_obj(f"{tmp}/path.obj")
text = [tuple(float(x) for x in l.split()) for l in open(f"{tmp}/path.txt")]
assert points == text, "OBJ vertices differ from the printed points"
assert len(points) >= 3 and faces == [] and lines == [list(range(1, len(points) + 1))], lines
s = mesh_vertices[0]
a, b, c = (mesh_vertices[v] for v in mesh_faces[100])
t = tuple(0.2 * a[k] + 0.3 * b[k] + 0.5 * c[k] for k in range(3))
assert math.dist(points[0], s) <= 1e-12, (points[0], s)
assert math.dist(points[-1], t) <= 1e-12, (points[-1], t)
length = sum(math.dist(p, q) for p, q in zip(points, points[1:]))
assert abs(length - distance) <= 1e-5 * distance, (length, distance)
PY
pass

# ---------------------------------------------------------------------------------------------
# render: a PNG of the requested size; colours, iso-lines and the path.
cat >"$tmp/png.py" <<'PY'
"""read_png(path) -> (width, height, rows of (r, g, b)); 8-bit RGB, non-interlaced only."""
import struct, zlib


def read_png(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "no PNG signature"
    pos, idat, ihdr = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        assert zlib.crc32(kind + body) == struct.unpack(">I", data[pos + 8 + length:pos + 12 + length])[0]
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    width, height, depth, colour, _, _, interlace = ihdr
    assert (depth, colour, interlace) == (8, 2, 0), ihdr
    raw = zlib.decompress(idat)
    stride = 3 * width
    rows, previous = [], bytearray(stride)
    for y in range(height):
        kind, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - 3] if i >= 3 else 0
            b = previous[i]
            c = previous[i - 3] if i >= 3 else 0
            if kind == 1: line[i] = (line[i] + a) & 255
            elif kind == 2: line[i] = (line[i] + b) & 255
            elif kind == 3: line[i] = (line[i] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
            else: assert kind == 0, kind
        rows.append([tuple(line[3 * x:3 * x + 3]) for x in range(width)])
        previous = line
    return width, height, rows
PY
render() {  # OUTPUT ARGS...
  local out=$1; shift
  "$geoprox" render "$spot" --graph "$graph" --source "$source" -o "$out" "$@" >"$tmp/out" \
    2>"$tmp/err" || fail "render $*: $(cat "$tmp/err")"
  [ ! -s "$tmp/out" ] || fail "render wrote to stdout"
}
render "$tmp/path.png" --target "$target" --width 320 --height 200 --view 120,20
grep -q "^geoprox: render: wrote $tmp/path.png (320x200, distances 0\.\.1\.5[0-9]*, 10 iso-lines every 0\.14[0-9]*, path of length $distance)\$" \
  "$tmp/err" || fail "render message: $(cat "$tmp/err")"; pass
render "$tmp/plain.png" --width 320 --height 200 --view 120,20 --isolines 0
render "$tmp/lines.png" --width 320 --height 200 --view 120,20 --isolines 12
# A decal: a checkerboard through the exponential map of the source (paper Fig. 14).
render "$tmp/decal.png" --width 320 --height 200 --view 120,20 --isolines 0 --decal-radius 0.5 --decal-squares 8
grep -q "decal of [1-9][0-9]* vertices)\$" "$tmp/err" || fail "render decal message: $(cat "$tmp/err")"; pass
# The IHDR bytes as written: width 320 and height 200, 8-bit RGB.
[ "$(od -An -tx1 -j12 -N17 "$tmp/path.png" | tr -d ' \n')" = "4948445200000140000000c80802000000" ] ||
  fail "IHDR bytes: $(od -An -tx1 -j12 -N17 "$tmp/path.png")"; pass
"$geoprox" render "$tmp/two.obj" --graph "$tmp/two.geoprox" --source v:0 -o "$tmp/two.png" \
  --width 160 --height 100 --view 20,30 2>"$tmp/err" || fail "render of two components: $(cat "$tmp/err")"
python3 - "$tmp" <<'PY' || fail "rendered pictures are wrong"
import sys
sys.path.insert(0, sys.argv[1])
from png import read_png
tmp = sys.argv[1]
pictures = {name: read_png(f"{tmp}/{name}.png") for name in ("path", "plain", "lines")}
for name, (w, h, rows) in pictures.items():
    assert (w, h, len(rows)) == (320, 200, 200), (name, w, h)
    pixels = [p for row in rows for p in row]
    assert len(set(pixels)) > 500, (name, len(set(pixels)))
    # White background in the corners, the mesh in the middle.
    assert rows[0][0] == rows[0][-1] == rows[-1][0] == rows[-1][-1] == (255, 255, 255), name
    covered = sum(p != (255, 255, 255) for p in pixels)
    assert 0.2 * len(pixels) < covered < 0.9 * len(pixels), (name, covered)
# The path is (235, 40, 40); viridis and grey have no red pixel (r > 180 with g, b < 100).
red = lambda rows: sum(p[0] > 180 and p[1] < 100 and p[2] < 100 for row in rows for p in row)
dark = lambda rows: sum(sum(p) < 100 for row in rows for p in row)
assert red(pictures["path"][2]) > 50, red(pictures["path"][2])
assert red(pictures["plain"][2]) == 0, red(pictures["plain"][2])
# Unreachable triangles are shaded grey (r = g = b); the reachable ones are not.
w, h, rows = read_png(f"{tmp}/two.png")
grey = sum(p[0] == p[1] == p[2] and 35 < p[0] < 200 for row in rows for p in row)
coloured = sum(max(p) - min(p) > 30 for row in rows for p in row)
assert (w, h) == (160, 100) and grey > 300 and coloured > 300, (w, h, grey, coloured)
# Iso-lines: many more near-black pixels with 12 lines than with none.
assert dark(pictures["lines"][2]) > dark(pictures["plain"][2]) + 300, \
    (dark(pictures["lines"][2]), dark(pictures["plain"][2]))
# The decal's squares are nearly grey (light and dark), which viridis never is; outside the
# decal the picture is the plain one.
w, h, decal = read_png(f"{tmp}/decal.png")
greyish = lambda rows, lo, hi: sum(max(p) - min(p) < 40 and lo <= sum(p) / 3 <= hi for row in rows for p in row)
plain = pictures["plain"][2]
assert (w, h) == (320, 200)
for lo, hi in ((150, 250), (0, 100)):  # light squares, dark squares
    assert greyish(decal, lo, hi) > greyish(plain, lo, hi) + 300, \
        (lo, hi, greyish(decal, lo, hi), greyish(plain, lo, hi))
changed = sum(a != b for ra, rb in zip(decal, plain) for a, b in zip(ra, rb))
assert 300 < changed < 0.5 * w * h, changed
PY
pass

# ---------------------------------------------------------------------------------------------
# Errors: one line 'geoprox: error: ...', the documented exit code, no output file
# (expect_geoprox_error in lib.sh).
expect_geoprox_error 1 '--graph is required' field "$spot" --source v:0 --out "$tmp/never.out"
expect_geoprox_error 1 '--graph is required' path "$spot" --source v:0 --target v:1 --out "$tmp/never.out"
expect_geoprox_error 1 '--graph is required' render "$spot" --source v:0 -o "$tmp/never.out"
expect_geoprox_error 1 '--out is required' render "$spot" --graph "$graph" --source v:0
expect_geoprox_error 2 '[BadPointSyntax]' field "$spot" --graph "$graph" --source v:x --out "$tmp/never.out"
expect_geoprox_error 2 '[VertexOutOfRange]' path "$spot" --graph "$graph" --source v:0 --target v:99999 --out "$tmp/never.out"
expect_geoprox_error 2 '[FaceOutOfRange]' render "$spot" --graph "$graph" --source v:0 --target f:9999:1:0:0 -o "$tmp/never.out"
expect_geoprox_error 2 "cannot write '$tmp/no/dir/f.ply'" field "$spot" --graph "$graph" --source v:0 --out "$tmp/no/dir/f.ply"
grep -qF '[WriteFailed]' "$tmp/err" || fail "unwritable field output: $(cat "$tmp/err")"; pass
expect_geoprox_error 2 '[WriteFailed]' path "$spot" --graph "$graph" --source v:0 --target v:1 --out "$tmp/no/dir/p.obj"
expect_geoprox_error 2 '[WriteFailed]' render "$spot" --graph "$graph" --source v:0 -o "$tmp/no/dir/r.png"
expect_geoprox_error 2 '[Unreachable]' path "$tmp/two.obj" --graph "$tmp/two.geoprox" --source v:0 --target v:5 --out "$tmp/never.out"
expect_geoprox_error 2 '[Unreachable]' render "$tmp/two.obj" --graph "$tmp/two.geoprox" --source v:0 --target v:5 -o "$tmp/never.out"
expect_geoprox_error 1 '--decal-radius' render "$spot" --graph "$graph" --source v:0 --decal-radius -1 -o "$tmp/never.out"
expect_geoprox_error 1 '--view: must be AZIMUTH,ELEVATION' render "$spot" --graph "$graph" --source v:0 --view 30 -o "$tmp/never.out"
expect_geoprox_error 1 '--width' render "$spot" --graph "$graph" --source v:0 --width 0 -o "$tmp/never.out"
expect_geoprox_error 1 '--out requires --mesh-file' remote field spot v:0 --out "$tmp/never.out"
[ ! -e "$tmp/no" ] || fail "an output directory was created"; pass

# ---------------------------------------------------------------------------------------------
# remote field --out and remote path --out: the same files from a daemon on the same graph.
start_daemon
"$geoprox" remote field spot v:0 --out "$tmp/remote.ply" --mesh-file "$spot" >"$tmp/out" 2>"$tmp/err" ||
  fail "remote field --out: $(cat "$tmp/err")"
[ ! -s "$tmp/out" ] || fail "remote field --out wrote to stdout"; pass
grep -q "^geoprox: field: wrote $tmp/remote.ply (2930 vertices, 5856 faces, " "$tmp/err" ||
  fail "remote field --out message: $(cat "$tmp/err")"; pass
"$geoprox" remote path spot "$source" "$target" --out "$tmp/remote.obj" >"$tmp/out" 2>"$tmp/err" ||
  fail "remote path --out: $(cat "$tmp/err")"
[ ! -s "$tmp/out" ] || fail "remote path --out wrote to stdout"; pass
python3 - "$tmp" <<'PY' || fail "remote result files differ from the offline ones"
import math, sys
sys.path.insert(0, sys.argv[1])
from result_files import read_ply, read_obj
tmp = sys.argv[1]
offline, remote = read_ply(f"{tmp}/field.ply"), read_ply(f"{tmp}/remote.ply")
strip = lambda header: [l for l in header if not l.startswith("comment geoprox")]
assert strip(offline[0]) == strip(remote[0]), (offline[0], remote[0])
assert offline[2] == remote[2]
for a, b in zip(offline[1], remote[1]):
    assert a[:3] == b[:3] and a[4:] == b[4:] and abs(a[3] - b[3]) <= 6e-8 * a[3], (a, b)
points, _, lines = read_obj(f"{tmp}/path.obj")
remote_points, _, remote_lines = read_obj(f"{tmp}/remote.obj")
assert lines == remote_lines, (lines, remote_lines)
assert all(math.dist(p, q) <= 1e-12 for p, q in zip(points, remote_points)), (points, remote_points)
PY
pass
expect_geoprox_error 2 '[MeshMismatch]' remote field spot v:0 --out "$tmp/never.out" \
  --mesh-file "$root/data/meshes/ChineseDragon-10kv.off"
expect_geoprox_error 2 '[FileNotFound]' remote field spot v:0 --out "$tmp/never.out" --mesh-file "$tmp/none.obj"
expect_geoprox_error 6 '[UnknownMesh]' remote path nope v:0 v:1 --out "$tmp/never.out"

echo "results_test.sh: $checks checks passed"
