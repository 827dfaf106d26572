#!/usr/bin/env bash
# End-to-end test of `geoprox eval`: the accuracy report of a small graph of the shipped sample
# mesh against the exact solver (no answer below the exact distance, none beyond Theorem 4.2's
# bound, paths as long as their distances, graph answers far closer than fast marching's), the
# same figures for the same seed, the JSON line, a graph without a bound, and bad input.
# Usage: bash eval_test.sh GEOPROX_BINARY REPO_ROOT
set -euo pipefail
# shellcheck source=lib.sh
source "$(dirname "$0")/lib.sh"
cli_test_setup "$@"

require_spot

"$geoprox" build "$spot" -o "$tmp/spot.geoprox" --samples 300 --neighbors 10 -q >/dev/null 2>"$tmp/err" ||
  fail "build failed: $(cat "$tmp/err")"
eval_spot() {  # OUT [SEED]
  "$geoprox" eval "$spot" "$tmp/spot.geoprox" --pairs 200 --fields 2 --paths 20 --seed "${2:-3}" \
    --json >"$1" 2>"$tmp/err" || fail "eval failed: $(cat "$tmp/err")"
}
eval_spot "$tmp/a"
grep -q '^pairs *200 (' "$tmp/a" || fail "eval lacks the pair count: $(cat "$tmp/a")"; pass
grep -q '^error bound *[0-9.]* (Theorem 4.2: 2r / (rho - 2r)); pairs beyond it: 0$' "$tmp/a" ||
  fail "eval: bound line: $(grep bound "$tmp/a")"; pass

# The figures, from the JSON line (the last line of the report).
tail -n 1 "$tmp/a" >"$tmp/a.json"
python3 - "$tmp/a.json" <<'EOF' || fail "eval figures: $(cat "$tmp/a.json")"
import json, math, sys
r = json.load(open(sys.argv[1]))
# --fields 2: two fields of each kind of source (vertex, edge, face, three points).
assert r["pairs"] == 200 and r["unreachable"] == 0 and r["fields"] == 8, r
kinds = r["field_error_by_source"]
assert sorted(kinds) == ["edge", "face", "multi", "vertex"], kinds
for kind, e in kinds.items():
    assert e["below_exact"] == 0 and 0 < e["mean"] < 0.03 and e["max"] >= e["p99"] >= 0, (kind, e)
# Every graph answer is the length of a real path: never below the exact distance.
assert r["error"]["below_exact"] == 0 and r["field_error"]["below_exact"] == 0, r
# Theorem 4.2 (finite on spot) holds for every pair.
assert r["error_bound"] is not None and math.isfinite(r["error_bound"]), r
assert r["beyond_bound"] == 0, r
# A good approximation (300 samples, m_P 10 on 5,856 faces; measured 0.49% mean, 5.0% worst),
# far closer than fast marching (3.5% mean here).
assert 0 < r["error"]["mean"] < 0.02 and r["error"]["max"] < 0.15, r
assert r["error"]["mean"] < r["fmm_error"]["mean"] / 3, r
assert 0 < r["field_error"]["mean"] < 0.03, r
# Paths are as long as the distances they come with.
assert r["path_length_error_max"] < 1e-6, r
assert r["p2p_ms"]["p50"] > 0 and r["field_ms"] > 0, r
EOF
pass

# The same seed gives the same points and so the same errors; another seed other points.
eval_spot "$tmp/b"
diff <(grep -v 'time\|^{' "$tmp/a") <(grep -v 'time\|^{' "$tmp/b") >/dev/null ||
  fail "same seed, other figures: $(diff <(grep -v 'time\|^{' "$tmp/a") <(grep -v 'time\|^{' "$tmp/b"))"; pass
eval_spot "$tmp/c" 4
[ "$(grep '^worst pair' "$tmp/a")" != "$(grep '^worst pair' "$tmp/c")" ] ||
  fail "seeds 3 and 4 gave the same worst pair"; pass

# A mesh whose long faces leave gaps between the samples (write_long_faced_strip_obj), built
# without the internal refinement: no bound to check against, and eval says why.
write_long_faced_strip_obj "$tmp/strip.obj"
"$geoprox" build "$tmp/strip.obj" -o "$tmp/strip.geoprox" --no-refine -q >/dev/null 2>&1 ||
  fail "strip build failed"
"$geoprox" eval "$tmp/strip.obj" "$tmp/strip.geoprox" --pairs 100 --fields 1 --no-fmm --json \
  >"$tmp/strip" 2>"$tmp/err" || fail "strip eval failed: $(cat "$tmp/err")"
grep -q '^error bound *none (Theorem 4.2 needs rho > 2r; r 4.51' "$tmp/strip" ||
  fail "strip bound line: $(grep bound "$tmp/strip")"; pass
tail -n 1 "$tmp/strip" | python3 -c '
import json, sys
r = json.load(sys.stdin)
assert r["error_bound"] is None and r["error"]["below_exact"] == 0, r' || fail "strip JSON"; pass
# Refined internally (the default), the same strip is answered within the aims of clean scans.
"$geoprox" build "$tmp/strip.obj" -o "$tmp/strip.geoprox" -q >/dev/null 2>&1 || fail "strip build failed"
"$geoprox" eval "$tmp/strip.obj" "$tmp/strip.geoprox" --pairs 200 --fields 1 --no-fmm --json \
  >"$tmp/strip" 2>"$tmp/err" || fail "strip eval failed: $(cat "$tmp/err")"
tail -n 1 "$tmp/strip" | python3 -c '
import json, sys
r = json.load(sys.stdin)
assert r["error_bound"] is not None and r["error"]["below_exact"] == 0, r
assert r["error"]["mean"] < 0.003 and r["error"]["max"] < 0.02, r["error"]
assert r["field_error"]["max"] < 0.03 and r["field_error"]["below_exact"] == 0, r' ||
  fail "refined strip JSON: $(tail -n 1 "$tmp/strip")"; pass

# A graph built for another mesh is refused.
set +e
"$geoprox" eval "$tmp/strip.obj" "$tmp/spot.geoprox" --pairs 10 >/dev/null 2>"$tmp/err"; rc=$?
set -e
[ "$rc" -eq 2 ] || fail "eval with another mesh's graph: exit $rc (expected 2)"; pass
grep -q 'MeshMismatch' "$tmp/err" || fail "no MeshMismatch: $(cat "$tmp/err")"; pass

echo "eval_test.sh: $checks checks passed"
