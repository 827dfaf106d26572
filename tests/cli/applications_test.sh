#!/usr/bin/env bash
# End-to-end test of `geoprox expmap` and `geoprox spline` on a flat grid: the exact map is an
# isometry (u^2 + v^2 = squared distance), the graph map covers the same disk, a Bezier curve
# starts and ends at its end control points and is the planar curve, bad input exits 2.
# Usage: bash applications_test.sh GEOPROX_BINARY REPO_ROOT
set -euo pipefail
# shellcheck source=lib.sh
source "$(dirname "$0")/lib.sh"
cli_test_setup "$@"

# A flat 12 x 12 grid of unit cells: vertex (i, j) is j*13 + i.
n=12
write_grid_obj $n "$tmp/grid.obj"
"$geoprox" build "$tmp/grid.obj" -o "$tmp/grid.geoprox" --samples 30 --neighbors 6 -q >/dev/null 2>"$tmp/err" ||
  fail "build failed: $(cat "$tmp/err")"

# Exact map around vertex (6, 6) = 84, radius 4.5: exactly the vertices within 4.5, at their
# Euclidean distance.
"$geoprox" expmap "$tmp/grid.obj" --exact --source v:84 --radius 4.5 >"$tmp/exact.txt" 2>"$tmp/err" ||
  fail "expmap --exact failed: $(cat "$tmp/err")"
expected=$(awk -v n=$n 'BEGIN { for (j = 0; j <= n; j++) for (i = 0; i <= n; i++) if ((i-6)^2 + (j-6)^2 <= 4.5^2) c++; print c }')
[ "$(wc -l <"$tmp/exact.txt")" -eq "$expected" ] || fail "exact map has $(wc -l <"$tmp/exact.txt") vertices, expected $expected"; pass
awk -v n=$n '{ i = $1 % (n + 1); j = int($1 / (n + 1)); d2 = (i-6)^2 + (j-6)^2; e = $2^2 + $3^2 - d2; if (e < 0) e = -e; if (e > 1e-9) bad++ }
  END { exit bad > 0 }' "$tmp/exact.txt" || fail "exact map is not an isometry: $(head -3 "$tmp/exact.txt")"; pass
grep -q "timing: exponential map of $expected vertices" "$tmp/err" || fail "no timing line: $(cat "$tmp/err")"; pass

# Graph map: the vertices whose graph distance (`geoprox field`) is within the radius, a subset of
# the exact disk (graph distances are upper bounds), each no closer than its Euclidean distance.
"$geoprox" expmap "$tmp/grid.obj" --graph "$tmp/grid.geoprox" --source v:84 --radius 4.5 >"$tmp/graph.txt" 2>"$tmp/err" ||
  fail "expmap --graph failed: $(cat "$tmp/err")"
"$geoprox" field "$tmp/grid.obj" --graph "$tmp/grid.geoprox" --source v:84 2>/dev/null >"$tmp/field.txt"
awk '$1 <= 4.5 { print NR - 1 }' "$tmp/field.txt" >"$tmp/field_inside.txt"
cut -d' ' -f1 "$tmp/graph.txt" | cmp -s - "$tmp/field_inside.txt" ||
  fail "graph map vertices differ from the field's disk: $(wc -l <"$tmp/graph.txt") vs $(wc -l <"$tmp/field_inside.txt")"; pass
[ "$(wc -l <"$tmp/graph.txt")" -gt $((expected / 2)) ] || fail "graph map has only $(wc -l <"$tmp/graph.txt") vertices"; pass
awk -v n=$n '{ i = $1 % (n + 1); j = int($1 / (n + 1)); if ($2^2 + $3^2 < (i-6)^2 + (j-6)^2 - 1e-9) bad++ } END { exit bad > 0 }' "$tmp/graph.txt" ||
  fail "graph map below the Euclidean distance"; pass

# Bezier through v:0 (0,0), v:6 (6,0), v:162 (6,12), v:168 (12,12), exact geodesics: the planar
# cubic. 11 samples at t = k/10.
"$geoprox" spline "$tmp/grid.obj" --exact --type bezier --samples 11 --control v:0 v:6 v:162 v:168 >"$tmp/curve.xyz" 2>"$tmp/err" ||
  fail "spline failed: $(cat "$tmp/err")"
[ "$(wc -l <"$tmp/curve.xyz")" -eq 11 ] || fail "expected 11 curve points"; pass
awk '{ t = (NR - 1) / 10; s = 1 - t;
       x = 3*s*s*t*6 + 3*s*t*t*6 + t*t*t*12; y = 3*s*t*t*12 + t*t*t*12;
       e = ($1 - x)^2 + ($2 - y)^2 + $3^2; if (e > 1e-18) bad++ } END { exit bad > 0 }' "$tmp/curve.xyz" ||
  fail "the exact Bezier is not the planar one: $(cat "$tmp/curve.xyz")"; pass
# Graph geodesics: same ends exactly.
"$geoprox" spline "$tmp/grid.obj" --graph "$tmp/grid.geoprox" --type bspline --samples 5 --control v:0 v:6 v:162 v:168 v:80 >"$tmp/bs.xyz" 2>"$tmp/err" ||
  fail "graph bspline failed: $(cat "$tmp/err")"
[ "$(wc -l <"$tmp/bs.xyz")" -eq 5 ] || fail "expected 5 B-spline points"; pass

# Refusals: exit 2, one line with the reason.
expect_refused() {  # REASON ARGS...
  local reason=$1; shift
  set +e
  "$geoprox" "$@" >/dev/null 2>"$tmp/err"; local rc=$?
  set -e
  [ "$rc" -eq 2 ] || fail "$*: exit $rc (expected 2): $(cat "$tmp/err")"
  [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "$*: not one line on stderr: $(cat "$tmp/err")"
  grep -q "\[$reason\]" "$tmp/err" || fail "$*: expected $reason, got: $(cat "$tmp/err")"
  pass
}
expect_refused BadControlPoints spline "$tmp/grid.obj" --exact --control v:0 v:1 v:2 v:3 v:4
expect_refused VertexOutOfRange expmap "$tmp/grid.obj" --exact --source v:9999 --radius 1
expect_refused MissingGraph expmap "$tmp/grid.obj" --source v:0 --radius 1
echo "applications_test.sh: $checks checks passed"
