#!/usr/bin/env bash
# End-to-end test of `geoprox build` and `geoprox inspect`: a graph file of the shipped sample
# mesh, its statistics, verification against the right and a wrong mesh, damaged files, and the
# warning for a mesh whose long faces leave points far from every sample.
# Usage: bash graph_test.sh GEOPROX_BINARY REPO_ROOT
set -euo pipefail
# shellcheck source=lib.sh
source "$(dirname "$0")/lib.sh"
cli_test_setup "$@"

require_spot

# Build with explicit parameters, twice with different thread counts: identical files.
"$geoprox" build "$spot" -o "$tmp/a.geoprox" --samples 200 --neighbors 12 --threads 1 -q >"$tmp/build1" 2>"$tmp/err" ||
  fail "build failed: $(cat "$tmp/err")"
"$geoprox" build "$spot" -o "$tmp/b.geoprox" --samples 200 --neighbors 12 --threads 2 -q >"$tmp/build2" 2>"$tmp/err" ||
  fail "build (2 threads) failed: $(cat "$tmp/err")"
cmp -s "$tmp/a.geoprox" "$tmp/b.geoprox" || fail "1 and 2 threads gave different files"; pass
grep -q '^samples *200 (m_P 12' "$tmp/build1" || fail "build summary lacks the samples: $(cat "$tmp/build1")"; pass
[ ! -s "$tmp/err" ] || fail "quiet build wrote to stderr: $(cat "$tmp/err")"; pass
ls "$tmp" | grep -q tmp && fail "temporary files left behind: $(ls "$tmp")"; pass
# r over the whole surface, with the vertices' own figure and where the farthest point is; a
# finite Theorem 4.2 bound on spot.
grep -q '^r covering *[0-9.e-]* (vertices [0-9.e-]*; farthest [vef]:[0-9]' "$tmp/build1" ||
  fail "build summary lacks r: $(cat "$tmp/build1")"; pass
grep -q '^error bound *[0-9.]* (Theorem 4.2' "$tmp/build1" ||
  fail "no finite error bound on spot: $(cat "$tmp/build1")"; pass

# inspect: header and statistics; --verify against the right mesh.
"$geoprox" inspect "$tmp/a.geoprox" --verify "$spot" >"$tmp/inspect" 2>"$tmp/err" ||
  fail "inspect failed: $(cat "$tmp/err")"
grep -q '^samples *200 (m_P 12' "$tmp/inspect" || fail "inspect lacks samples: $(cat "$tmp/inspect")"; pass
grep -q '^mesh *2930 vertices, 5856 faces' "$tmp/inspect" || fail "inspect lacks mesh counts"; pass
grep -q '^verify .* matches' "$tmp/inspect" || fail "inspect --verify did not confirm"; pass
# Every sample has at least m_P neighbours.
min_degree=$(sed -n 's/^degree *min \([0-9]*\),.*/\1/p' "$tmp/inspect")
[ "$min_degree" -ge 12 ] || fail "minimum degree $min_degree < 12"; pass

# Built for another mesh: refused, naming the mismatch.
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n' >"$tmp/other.obj"
set +e
"$geoprox" inspect "$tmp/a.geoprox" --verify "$tmp/other.obj" >/dev/null 2>"$tmp/err"; rc=$?
set -e
[ "$rc" -eq 2 ] || fail "verify against another mesh: exit $rc"; pass
grep -q 'MeshMismatch' "$tmp/err" || fail "no MeshMismatch: $(cat "$tmp/err")"; pass

# Damaged files: truncated, a flipped byte, not a graph file at all, missing.
size=$(stat -c %s "$tmp/a.geoprox")
head -c $((size / 2)) "$tmp/a.geoprox" >"$tmp/cut.geoprox"
cp "$tmp/a.geoprox" "$tmp/flip.geoprox"
printf '\xff' | dd of="$tmp/flip.geoprox" bs=1 seek=$((size - 100)) conv=notrunc status=none
expect_error() {  # FILE REASON
  set +e
  "$geoprox" inspect "$1" >/dev/null 2>"$tmp/err"; local rc=$?
  set -e
  [ "$rc" -eq 2 ] || fail "inspect $1: exit $rc (expected 2)"
  [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "inspect $1: not one line on stderr: $(cat "$tmp/err")"
  grep -q "$2" "$tmp/err" || fail "inspect $1: expected $2, got: $(cat "$tmp/err")"
  pass
}
expect_error "$tmp/cut.geoprox" Truncated
expect_error "$tmp/flip.geoprox" 'ChecksumMismatch\|CorruptGraph'
expect_error "$spot" ForeignFile
expect_error "$tmp/missing.geoprox" FileNotFound

# A flat 10 x 1 strip (write_long_faced_strip_obj): a 10 x 10 grid, then eleven long faces with
# no vertex inside. With --no-refine every vertex becomes a sample, yet the long faces' middles
# are 4.51 from all of them, beyond the link radius: the build succeeds and warns on stderr,
# naming the faces and the remedy; inspect warns from r and rho.
write_long_faced_strip_obj "$tmp/strip.obj"
"$geoprox" build "$tmp/strip.obj" -o "$tmp/strip.geoprox" --no-refine -q >"$tmp/out" 2>"$tmp/err" ||
  fail "strip build failed: $(cat "$tmp/err")"
[ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "strip build: not one warning line: $(cat "$tmp/err")"; pass
grep -q '^geoprox: warning: 11 faces (90% of the area) hold points with no sample within the link radius' "$tmp/err" ||
  fail "strip build warning: $(cat "$tmp/err")"; pass
grep -q 'without --no-refine' "$tmp/err" || fail "the warning names no remedy: $(cat "$tmp/err")"; pass
grep -q '^r covering *4.51[0-9]* (vertices 0;' "$tmp/out" || fail "strip r: $(cat "$tmp/out")"; pass
grep -q '^error bound *inf' "$tmp/out" || fail "strip bound: $(cat "$tmp/out")"; pass
"$geoprox" inspect "$tmp/strip.geoprox" >"$tmp/out" 2>"$tmp/err" || fail "strip inspect failed"
grep -q '^geoprox: warning: some points are up to 4.51[0-9]* from every sample, beyond the link radius' "$tmp/err" ||
  fail "strip inspect warning: $(cat "$tmp/err")"; pass

# By default the build refines the strip internally instead: no warning, a finite bound, a
# version-3 file that inspect describes, and queries in the strip's own ids (vertex 122 is its
# corner (10, 1); face 210 is its last long face).
"$geoprox" build "$tmp/strip.obj" -o "$tmp/strip.geoprox" -q >"$tmp/out" 2>"$tmp/err" ||
  fail "strip refined build failed: $(cat "$tmp/err")"
[ ! -s "$tmp/err" ] || fail "strip refined build warned: $(cat "$tmp/err")"; pass
grep -q '^refined *to [0-9]* vertices, [0-9]* faces (edges <= [0-9.]*): the first pass left points 4.51[0-9]* from every sample, over half its link radius [0-9.]* (11 faces, 90% of the area, beyond it)' "$tmp/out" ||
  fail "strip refined line: $(cat "$tmp/out")"; pass
grep -q '^error bound *[0-9.]* (Theorem' "$tmp/out" || fail "strip refined bound: $(cat "$tmp/out")"; pass
"$geoprox" inspect "$tmp/strip.geoprox" --verify "$tmp/strip.obj" >"$tmp/out" 2>"$tmp/err" ||
  fail "strip refined inspect failed: $(cat "$tmp/err")"
grep -q 'format version 3' "$tmp/out" && grep -q '^mesh *123 vertices, 211 faces' "$tmp/out" &&
  grep -q '^refined *to ' "$tmp/out" && grep -q '^verify .* matches' "$tmp/out" ||
  fail "strip refined inspect: $(cat "$tmp/out")"; pass
printf 'v:0 v:122\nf:210:0.2:0.3:0.5 v:0\n' >"$tmp/pairs"
"$geoprox" distance "$tmp/strip.obj" -g "$tmp/strip.geoprox" --pairs "$tmp/pairs" >"$tmp/out" 2>"$tmp/err" ||
  fail "strip distance failed: $(cat "$tmp/err")"
python3 - "$tmp/out" <<'PY' || fail "strip distances: $(cat "$tmp/out")"
import math, sys
got = [float(x) for x in open(sys.argv[1]).read().split()]
# Straight lines on the flat strip; the graph answer is never below and here within 2%.
# (face 210's corners: the grid's corner (1, 1), then (10, 0) and (10, 1))
face_210 = (0.2 * 1 + 0.3 * 10 + 0.5 * 10, 0.2 * 1 + 0.3 * 0 + 0.5 * 1)
for d, truth in zip(got, [math.hypot(10, 1), math.hypot(*face_210)]):
    assert truth * (1 - 1e-12) <= d <= truth * 1.02, (d, truth)
PY
pass
"$geoprox" field "$tmp/strip.obj" -g "$tmp/strip.geoprox" --source v:0 >"$tmp/out" 2>/dev/null ||
  fail "strip field failed"
[ "$(wc -l <"$tmp/out")" -eq 123 ] || fail "strip field: not one value per vertex of the strip"; pass

# A mesh of polygons: a unit cube of five quads and one face as two triangles loads as twelve
# triangles, and the geodesic between opposite corners is the cube's, sqrt(5) over two faces.
cat >"$tmp/cube.obj" <<'OBJ'
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
f 1 4 3 2
f 5 6 7 8
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f 4 1 5
f 4 5 8
OBJ
"$geoprox" build "$tmp/cube.obj" -o "$tmp/cube.geoprox" -q >"$tmp/out" 2>"$tmp/err" ||
  fail "cube build failed: $(cat "$tmp/err")"
grep -q '^mesh .*(8 vertices, 12 faces)' "$tmp/out" || fail "cube: $(head -1 "$tmp/out")"; pass
printf 'v:0 v:6\n' >"$tmp/pairs"
"$geoprox" distance "$tmp/cube.obj" -g "$tmp/cube.geoprox" --pairs "$tmp/pairs" >"$tmp/out" ||
  fail "cube distance failed"
python3 -c 'import math,sys; d=float(open(sys.argv[1]).read()); assert abs(d - math.sqrt(5)) < 1e-9, d' "$tmp/out" ||
  fail "cube corner to corner: $(cat "$tmp/out") (expected sqrt 5)"; pass

# A bad option value is a usage error.
set +e
"$geoprox" build "$spot" -o "$tmp/c.geoprox" --sampling nope >/dev/null 2>&1; rc=$?
set -e
[ "$rc" -eq 1 ] || fail "--sampling nope: exit $rc (expected 1)"; pass

echo "graph_test.sh: $checks checks passed"
