#!/usr/bin/env bash
# End-to-end test of `--metric` (docs/metrics.md) on `geoprox exact`, `geoprox build` and
# `geoprox inspect --verify`: a flat grid under a uniform scaling metric, a graph built under it
# refused without it, and refused metrics naming the face.
# Usage: bash metric_test.sh GEOPROX_BINARY REPO_ROOT
set -euo pipefail
# shellcheck source=lib.sh
source "$(dirname "$0")/lib.sh"
cli_test_setup "$@"

# A flat 8 x 8 grid of unit cells: 81 vertices, 128 faces; vertex (i, j) is j*9 + i.
n=8
write_grid_obj $n "$tmp/grid.obj"
faces=$((2 * n * n))
# Uniform scaling by 3: every length and distance times 3.
{ echo "geoprox-metric 1 face-tensor-3d"; for _ in $(seq $faces); do echo "9 0 0 9 0 9"; done; } >"$tmp/scale3.metric"

# exact: v:0 -> v:80 (the far corner) is 3 * 8 * sqrt(2).
plain=$("$geoprox" exact "$tmp/grid.obj" --source v:0 --to v:80 | sed -n 's/^distance //p')
scaled=$("$geoprox" exact "$tmp/grid.obj" --source v:0 --to v:80 --metric "$tmp/scale3.metric" | sed -n 's/^distance //p')
awk -v p="$plain" -v s="$scaled" 'BEGIN { e = 8 * sqrt(2); exit !(p - e < 1e-12 && e - p < 1e-12 && s - 3 * e < 1e-11 && 3 * e - s < 1e-11) }' ||
  fail "distances $plain (plain) and $scaled (metric), expected $(awk 'BEGIN { print 8 * sqrt(2) }') and 3 times that"; pass
# Every vertex distance scales by 3.
"$geoprox" exact "$tmp/grid.obj" --source v:40 >"$tmp/plain.txt"
"$geoprox" exact "$tmp/grid.obj" --source v:40 --metric "$tmp/scale3.metric" >"$tmp/scaled.txt"
paste "$tmp/plain.txt" "$tmp/scaled.txt" |
  awk '{ d = $2 - 3 * $1; if (d < 0) d = -d; if (d > 1e-9 * ($2 + 1)) bad++ } END { exit bad > 0 || NR != 81 }' ||
  fail "per-vertex distances are not 3 times the plain ones"; pass

# build --metric; inspect --verify with the metric matches, without it is MeshMismatch.
"$geoprox" build "$tmp/grid.obj" -o "$tmp/g.geoprox" --samples 16 --neighbors 5 --metric "$tmp/scale3.metric" -q >"$tmp/build" 2>"$tmp/err" ||
  fail "build --metric failed: $(cat "$tmp/err")"
grep -q "^metric *$tmp/scale3.metric" "$tmp/build" || fail "build summary does not name the metric: $(cat "$tmp/build")"; pass
"$geoprox" inspect "$tmp/g.geoprox" --verify "$tmp/grid.obj" --metric "$tmp/scale3.metric" >"$tmp/inspect" 2>"$tmp/err" ||
  fail "inspect --verify --metric failed: $(cat "$tmp/err")"
grep -q '^verify .* matches under the metric' "$tmp/inspect" || fail "verify did not confirm: $(cat "$tmp/inspect")"; pass
set +e
"$geoprox" inspect "$tmp/g.geoprox" --verify "$tmp/grid.obj" >/dev/null 2>"$tmp/err"; rc=$?
set -e
[ "$rc" -eq 2 ] || fail "a graph built under a metric verified without it (exit $rc)"; pass
grep -q 'MeshMismatch' "$tmp/err" || fail "no MeshMismatch: $(cat "$tmp/err")"; pass

# Refusals: exit 2, one line naming the face (or the line of the file) and the reason.
expect_refused() {  # METRIC_FILE PATTERN REASON
  set +e
  "$geoprox" exact "$tmp/grid.obj" --source v:0 --metric "$1" >/dev/null 2>"$tmp/err"; local rc=$?
  set -e
  [ "$rc" -eq 2 ] || fail "metric $1: exit $rc (expected 2): $(cat "$tmp/err")"
  [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "metric $1: not one line on stderr: $(cat "$tmp/err")"
  grep -q "$2" "$tmp/err" || fail "metric $1: expected '$2' in: $(cat "$tmp/err")"
  grep -q "\[$3\]" "$tmp/err" || fail "metric $1: expected reason $3 in: $(cat "$tmp/err")"
  pass
}
awk 'NR == 12 { print "1 0 0 -1 0 1"; next } { print }' "$tmp/scale3.metric" >"$tmp/indefinite.metric"
expect_refused "$tmp/indefinite.metric" 'face 10:' NotPositiveDefinite
head -n 100 "$tmp/scale3.metric" >"$tmp/short.metric"
expect_refused "$tmp/short.metric" "for a mesh with $faces faces" BadMetric
awk 'NR == 3 { print "9 0 0 9 zero 9"; next } { print }' "$tmp/scale3.metric" >"$tmp/word.metric"
expect_refused "$tmp/word.metric" 'word.metric:3:' ParseError
expect_refused "$tmp/missing.metric" 'missing.metric' FileNotFound
# Explicit lengths breaking a triangle inequality: edge 0 (v0-v1) far too long, in face 0.
{ echo "geoprox-metric 1 edge-lengths"; echo 5; for _ in $(seq $((3 * n * n + 2 * n - 1))); do echo 1.5; done; } >"$tmp/lengths.metric"
expect_refused "$tmp/lengths.metric" 'face 0:' TriangleInequality

echo "metric_test.sh: $checks checks passed"
