#!/usr/bin/env bash
# End-to-end test of `geoprox repair`: dirty meshes that `geoprox info` refuses come out as
# files it loads, with the counts, the map and the errors as documented (docs/meshes.md).
# Usage: bash repair_test.sh GEOPROX_BINARY REPO_ROOT
set -euo pipefail
# shellcheck source=lib.sh
source "$(dirname "$0")/lib.sh"
cli_test_setup "$@"

data="$root/tests/data"

# repair MESH OUT [ARGS...]: runs geoprox repair, which must succeed and write OUT.
repair() {
  local mesh=$1 out=$2
  shift 2
  expect_geoprox_ok "$tmp/report" repair "$mesh" -o "$out" "$@"
  [ -s "$out" ] || fail "geoprox repair $mesh wrote no $out"
  pass
}

# count_is LABEL NUMBER: the repair report's line LABEL starts with NUMBER.
count_is() {
  grep -Eq "^ *$1: $2([ ,]|\$)" "$tmp/report" || fail "report does not give $1 = $2:"$'\n'"$(cat "$tmp/report")"
  pass
}

# loads FILE: geoprox info accepts FILE; its report is left in $tmp/info.
loads() {
  expect_geoprox_ok "$tmp/info" info "$1"
  pass
}

# The bowtie (two triangles sharing one vertex) is refused, with a pointer to repair.
expect_geoprox_error 2 "geoprox repair" info "$data/bowtie.obj"
expect_geoprox_error 2 "[NonManifoldVertex]" info "$data/bowtie.obj"
repair "$data/bowtie.obj" "$tmp/bowtie.obj" --map "$tmp/bowtie.map"
count_is "vertices split" 1
count_is "vertices added" 1
count_is "output" "6 vertices, 2 faces, 2 components"
loads "$tmp/bowtie.obj"
# Vertex 0 keeps the first triangle; the copy, vertex 5 (OBJ 6), takes the second, where
# vertex 0 was.
grep -q '^f 1 2 3$' "$tmp/bowtie.obj" || fail "bowtie: first face changed: $(cat "$tmp/bowtie.obj")"
grep -q '^f 6 4 5$' "$tmp/bowtie.obj" || fail "bowtie: second face not on the copy: $(cat "$tmp/bowtie.obj")"
[ "$(grep -c '^v ' "$tmp/bowtie.obj")" -eq 6 ] || fail "bowtie: not 6 vertices"
[ "$(grep '^v ' "$tmp/bowtie.obj" | tail -1)" = "v 0 0 0" ] || fail "bowtie: the copy is not at vertex 0"
grep -q '^v 5 0$' "$tmp/bowtie.map" || fail "bowtie map: no 'v 5 0': $(cat "$tmp/bowtie.map")"
grep -q '^f 1 1$' "$tmp/bowtie.map" || fail "bowtie map: no 'f 1 1': $(cat "$tmp/bowtie.map")"
pass

# A face turned the wrong way round is turned back; exact distances then cross the diagonal.
expect_geoprox_error 2 "[InconsistentOrientation]" info "$data/flipped_face.obj"
repair "$data/flipped_face.obj" "$tmp/square.off" --map "$tmp/square.map"
count_is "faces flipped" 1
count_is "edges cut" 0
head -1 "$tmp/square.off" | grep -qx OFF || fail "square.off is not OFF: $(head -3 "$tmp/square.off")"
grep -q '^f 1 1 flipped$' "$tmp/square.map" || fail "square map: face 1 not flipped: $(cat "$tmp/square.map")"
"$geoprox" exact "$tmp/square.off" --source v:1 >"$tmp/d" || fail "exact on the repaired square"
awk 'NR == 4 { exit !($1 > 1.414213562372 && $1 < 1.414213562374) }' "$tmp/d" ||
  fail "square: d(1, 3) = $(sed -n 4p "$tmp/d"), not sqrt 2"
pass
# --no-orient cuts the square along its diagonal instead: two triangles apart.
repair "$data/flipped_face.obj" "$tmp/cut.obj" --no-orient
count_is "faces flipped" 0
count_is "edges cut" 1
count_is "output" "6 vertices, 2 faces, 2 components"

# Three faces on one edge: the edge is cut, each face keeps its own copy of it.
repair "$data/nonmanifold_edge.obj" "$tmp/book.obj"
count_is "edges cut" 1
count_is "output" "9 vertices, 3 faces, 3 components"
loads "$tmp/book.obj"

# A manifold mesh comes out the same: vertices bit for bit (%.17g), faces in order.
require_spot
repair "$spot" "$tmp/spot.obj"
count_is "vertices split" 0
count_is "output" "2930 vertices, 5856 faces, 1 components"
"$geoprox" exact "$spot" --source v:7 >"$tmp/a"
"$geoprox" exact "$tmp/spot.obj" --source v:7 >"$tmp/b"
cmp -s "$tmp/a" "$tmp/b" || fail "spot: exact distances differ after a repair that changed nothing"
pass

# The shipped STL whose welded corners leave non-manifold vertices.
repair "$root/data/meshes/pig.stl" "$tmp/pig.obj"
count_is "vertices split" 421
loads "$tmp/pig.obj"

# Errors: the output format, a missing input; the output file is not written.
expect_geoprox_error 2 "repair writes .obj or .off" repair "$data/bowtie.obj" -o "$tmp/never.out"
expect_geoprox_error 2 "[FileNotFound]" repair "$tmp/missing.obj" -o "$tmp/never.obj"
[ ! -e "$tmp/never.obj" ] || fail "a failed repair wrote its output"
expect_geoprox_error 1 "--out" repair "$data/bowtie.obj"

echo "repair_test.sh: $checks checks passed"
