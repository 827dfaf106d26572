#!/usr/bin/env bash
# End-to-end test of `geoprox refine`: the long-faced strip (write_long_faced_strip_obj), whose
# default graph leaves points far from every sample, refined to edges of half its link radius:
# the copy loads, keeps the input's vertices and unsplit faces, its map places every new vertex
# and split face on the input, and its graph draws no warning and has a Theorem 4.2 bound; a
# mesh with no long edge comes back the same; bad output names and limits are refused.
# Usage: bash refine_test.sh GEOPROX_BINARY REPO_ROOT
set -euo pipefail
# shellcheck source=lib.sh
source "$(dirname "$0")/lib.sh"
cli_test_setup "$@"

require_spot

write_long_faced_strip_obj "$tmp/strip.obj"
expect_geoprox_ok "$tmp/stdout" refine "$tmp/strip.obj" -o "$tmp/fine.obj" --map "$tmp/fine.map"
out=$(cat "$tmp/stdout")
grep -q '^ *input: 123 vertices, 211 faces, longest edge 9.05' <<<"$out" || fail "input line: $out"; pass
# Default limit: half the link radius of a default graph of the output. The input's (every
# vertex a sample, m_P 22: sqrt(44 * 10 / (pi * 123)) = 1.067) asks for edges of 0.53; the
# output has more faces, so Table 1 gives it 1300 samples and a link radius of
# sqrt(44 * 10 / (pi * 1300)) = 0.3282: refined again to edges of 0.1641, it asks for no less.
grep -q '^ *longest edge allowed: 0.1641[0-9]* (half the link radius 0.3282[0-9]* of a default graph of the output)' <<<"$out" ||
  fail "limit line: $out"; pass
vertices=$(sed -n 's/^ *output: \([0-9]*\) vertices, \([0-9]*\) faces, longest edge \(.*\)/\1/p' <<<"$out")
faces=$(sed -n 's/^ *output: \([0-9]*\) vertices, \([0-9]*\) faces, longest edge \(.*\)/\2/p' <<<"$out")
longest=$(sed -n 's/^ *output: .*longest edge \(.*\)/\1/p' <<<"$out")
[ "$faces" -gt 211 ] && [ "$vertices" -gt 123 ] || fail "nothing split: $out"; pass
awk -v l="$longest" 'BEGIN { exit !(l <= 0.16412) }' || fail "longest edge $longest left"; pass

# The copy: the input's 123 vertices first, unchanged, and every new one in the map.
expect_geoprox_ok "$tmp/stdout" info "$tmp/fine.obj"
grep -q "^ *vertices: $vertices$" "$tmp/stdout" || fail "info: $(cat "$tmp/stdout")"; pass
grep -q '^ *components: 1$' "$tmp/stdout" || fail "not one piece"; pass
diff <(grep '^v ' "$tmp/strip.obj" | head -n 123 | awk '{ print $2 + 0, $3 + 0, $4 + 0 }') \
  <(grep '^v ' "$tmp/fine.obj" | head -n 123 | awk '{ print $2 + 0, $3 + 0, $4 + 0 }') >/dev/null ||
  fail "the input's vertices moved"; pass
[ "$(grep -c '^v ' "$tmp/fine.map")" -eq $((vertices - 123)) ] || fail "map: not every new vertex"; pass
# A new vertex on the bottom side y = 0 of the long faces lies on an input edge.
grep -q '^v [0-9]* e:[0-9]*:0.5$' "$tmp/fine.map" || fail "no new vertex at an edge's middle: $(head "$tmp/fine.map")"; pass
# Split faces: the parts of an input face with their corners' barycentrics (nine numbers).
grep '^f ' "$tmp/fine.map" | awk 'NF != 12 { bad = 1 } END { exit bad }' || fail "map face lines"; pass
[ "$(grep -c '^f ' "$tmp/fine.map")" -ge $((faces - 211)) ] || fail "map: parts missing"; pass

# Its graph leaves no point beyond the link radius: no warning, and a bound.
expect_geoprox_ok "$tmp/stdout" build "$tmp/fine.obj" -o "$tmp/fine.geoprox" -q
grep -q '^error bound *[0-9.]* (Theorem' "$tmp/stdout" || fail "no bound: $(cat "$tmp/stdout")"; pass

# Nothing longer than the limit: the same mesh, nothing split.
expect_geoprox_ok "$tmp/stdout" refine "$spot" -o "$tmp/spot.off" --max-edge 1
grep -q '^ *faces split: 0 of 5856' "$tmp/stdout" || fail "spot split: $(cat "$tmp/stdout")"; pass
head -n 2 "$tmp/spot.off" | tail -n 1 | grep -q '^2930 5856 0$' || fail "spot.off counts"; pass

# Refused: an output that is neither OBJ nor OFF (2), a limit that is not positive (1).
set +e
"$geoprox" refine "$spot" -o "$tmp/x.ply" >/dev/null 2>"$tmp/err"; rc=$?
set -e
[ "$rc" -eq 2 ] && grep -q UnsupportedFormat "$tmp/err" || fail "x.ply: exit $rc, $(cat "$tmp/err")"; pass
set +e
"$geoprox" refine "$spot" -o "$tmp/x.obj" --max-edge 0 >/dev/null 2>&1; rc=$?
set -e
[ "$rc" -eq 1 ] || fail "--max-edge 0: exit $rc (expected 1)"; pass
[ ! -e "$tmp/x.obj" ] && [ ! -e "$tmp/x.ply" ] || fail "a refused refine wrote a file"; pass

echo "refine_test.sh: $checks checks passed"
