#!/usr/bin/env bash
# End-to-end test of --repair, which loads a mesh repaired instead of refusing it: every command
# that reads a mesh file takes it, says on stderr what repair changed, and uses the ids of the
# file `geoprox repair` writes, so that a graph built with --repair answers as one built on that
# file; geoproxd serves the same graph with "repair": true (docs/meshes.md).
# Usage: bash repair_flag_test.sh GEOPROX_BINARY REPO_ROOT
set -euo pipefail
# shellcheck source=lib.sh
source "$(dirname "$0")/lib.sh"
cli_test_setup "$@"

data="$root/tests/data"
pig="$root/data/meshes/pig.stl"
pig_repaired="geoprox: repaired $pig: 421 vertices split (+443 copies)"

# expect_repaired_line LINE: $tmp/err has LINE.
expect_repaired_line() {
  grep -qxF "$1" "$tmp/err" || fail "stderr lacks '$1': $(cat "$tmp/err")"
  pass
}

# run_ok OUT ARGS...: `geoprox ARGS` exits 0, stdout in OUT, stderr in $tmp/err.
run_ok() {
  local out=$1
  shift
  "$geoprox" "$@" >"$out" 2>"$tmp/err" || fail "geoprox $*: $(cat "$tmp/err")"
}

# Without --repair the bowtie is refused, and the error names the flag.
expect_geoprox_error 2 "[NonManifoldVertex] (--repair loads it repaired;" info "$data/bowtie.obj"
# info --repair: the report of the repaired mesh, one line on stderr saying what changed.
run_ok "$tmp/info" info "$data/bowtie.obj" --repair
grep -qE '^ *vertices: 6$' "$tmp/info" || fail "info --repair: $(cat "$tmp/info")"; pass
grep -qE '^ *components: 2$' "$tmp/info" || fail "info --repair: $(cat "$tmp/info")"; pass
[ "$(cat "$tmp/err")" = "geoprox: repaired $data/bowtie.obj: 1 vertex split (+1 copy)" ] ||
  fail "info --repair stderr: $(cat "$tmp/err")"; pass
# A mesh that needs no repair: nothing on stderr.
require_spot
expect_geoprox_ok "$tmp/info" info "$spot" --repair
pass

# exact --repair on the bowtie: vertex 0 keeps face 0, its copy (vertex 5) is face 1's corner.
run_ok "$tmp/exact" exact "$data/bowtie.obj" --repair --source v:5
[ "$(tr '\n' ' ' <"$tmp/exact")" = "inf inf inf 1 1.4142135623730951 0 " ] ||
  fail "exact --repair from the copy: $(cat "$tmp/exact")"; pass

# build --repair records what repair changed in its summary, and on stderr.
run_ok "$tmp/bowtie_build" build "$data/bowtie.obj" --repair -o "$tmp/bowtie.geoprox" -q
grep -qxF "repair          1 vertex split (+1 copy)" "$tmp/bowtie_build" ||
  fail "build --repair summary: $(cat "$tmp/bowtie_build")"; pass
grep -qE "^mesh +$data/bowtie.obj \(6 vertices, 2 faces\)$" "$tmp/bowtie_build" ||
  fail "build --repair mesh line: $(cat "$tmp/bowtie_build")"; pass
expect_repaired_line "geoprox: repaired $data/bowtie.obj: 1 vertex split (+1 copy)"
# A point on face 1 at its corner 0 is the copy: 0 from v:5, 1 from v:3, apart from v:0.
printf 'f:1:1:0:0 v:5\nf:1:1:0:0 v:3\nf:1:1:0:0 v:0\nv:0 v:3\nf:0:1:0:0 v:0\n' >"$tmp/bowtie_pairs"
run_ok "$tmp/d" distance "$data/bowtie.obj" --repair -g "$tmp/bowtie.geoprox" --pairs "$tmp/bowtie_pairs"
[ "$(tr '\n' ' ' <"$tmp/d")" = "0 1 inf inf 0 " ] || fail "bowtie distances: $(cat "$tmp/d")"; pass
# The graph is for the repaired mesh: without --repair the mesh does not load at all.
expect_geoprox_error 2 "[NonManifoldVertex]" distance "$data/bowtie.obj" -g "$tmp/bowtie.geoprox" \
  --pairs "$tmp/bowtie_pairs"

# pig.stl: a graph built with --repair answers as one built on the file `geoprox repair` writes.
expect_geoprox_ok "$tmp/report" repair "$pig" -o "$tmp/pig.obj" --map "$tmp/pig.map"
mkdir -p "$tmp/graphs"
run_ok "$tmp/build" build "$pig" --repair -o "$tmp/graphs/pig.geoprox" --samples 300 --neighbors 10 -q
grep -qxF "repair          421 vertices split (+443 copies)" "$tmp/build" ||
  fail "build --repair summary: $(cat "$tmp/build")"; pass
grep -qE '^mesh .*\(9085 vertices, 16848 faces\)$' "$tmp/build" || fail "$(cat "$tmp/build")"; pass
expect_repaired_line "$pig_repaired"
run_ok "$tmp/build2" build "$tmp/pig.obj" -o "$tmp/pig_file.geoprox" --samples 300 --neighbors 10 -q
# Pairs over vertices, a copy and a point on the face at it, in the component of vertex 0
# (v:1239 is its farthest vertex from v:0), and one pair into another component (v:8642).
copy=8682
grep -qx "v $copy 1028" "$tmp/pig.map" || fail "vertex $copy is no copy of 1028: $(head "$tmp/pig.map")"
at_copy=$(awk -v id=$((copy + 1)) '
  $1 == "f" { n++; if ($2 == id || $3 == id || $4 == id) { print n - 1; exit } }' "$tmp/pig.obj")
[ -n "$at_copy" ] || fail "no face of pig.obj at vertex $copy"
{
  echo "v:0 v:$copy"
  echo "v:$copy f:$at_copy:0.2:0.3:0.5"
  echo "f:$at_copy:0.2:0.3:0.5 v:1239"
  echo "v:0 v:1239"
  echo "e:300:0.25 f:7:0.3:0.3:0.4"
  echo "v:0 v:8642"
} >"$tmp/pairs"
run_ok "$tmp/d_repair" distance "$pig" --repair -g "$tmp/graphs/pig.geoprox" --pairs "$tmp/pairs"
expect_repaired_line "$pig_repaired"
run_ok "$tmp/d_file" distance "$tmp/pig.obj" -g "$tmp/pig_file.geoprox" --pairs "$tmp/pairs"
[ "$(wc -l <"$tmp/d_repair")" -eq 6 ] || fail "not 6 distances: $(cat "$tmp/d_repair")"; pass
cmp -s "$tmp/d_repair" "$tmp/d_file" ||
  fail "--repair and the repaired file differ: $(paste "$tmp/d_repair" "$tmp/d_file")"; pass
[ "$(grep -c '^inf$' "$tmp/d_repair")" -eq 1 ] || fail "not one pair unreachable: $(cat "$tmp/d_repair")"; pass
[ "$(tail -1 "$tmp/d_repair")" = inf ] || fail "v:8642 is reachable from v:0: $(cat "$tmp/d_repair")"; pass
# One graph serves both: the repaired file verifies against the graph built with --repair.
run_ok "$tmp/d_cross" distance "$tmp/pig.obj" -g "$tmp/graphs/pig.geoprox" --pairs "$tmp/pairs"
cmp -s "$tmp/d_repair" "$tmp/d_cross" || fail "the --repair graph answers otherwise on pig.obj"; pass
expect_geoprox_error 2 "(--repair loads it repaired;" distance "$pig" -g "$tmp/graphs/pig.geoprox" \
  --pairs "$tmp/pairs"

# inspect: the graph names its mesh as repaired, and verifies against it only with --repair.
run_ok "$tmp/inspect" inspect "$tmp/graphs/pig.geoprox" --verify "$pig" --repair
grep -qxF "source mesh     $pig (repaired)" "$tmp/inspect" || fail "$(cat "$tmp/inspect")"; pass
grep -qxF "verify          $pig (repaired) matches" "$tmp/inspect" || fail "$(cat "$tmp/inspect")"; pass
expect_geoprox_error 2 "[NonManifoldVertex]" inspect "$tmp/graphs/pig.geoprox" --verify "$pig"
expect_geoprox_error 1 "--repair requires --verify" inspect "$tmp/graphs/pig.geoprox" --repair

# The other commands that read the mesh take --repair too, and say so (points on the face at
# the copy, all in one component).
g="$tmp/graphs/pig.geoprox"
run_ok "$tmp/field" field "$pig" --repair -g "$g" -s "v:$copy"
[ "$(wc -l <"$tmp/field")" -eq 9085 ] || fail "field --repair: not 9085 lines"; pass
[ "$(sed -n "$((copy + 1))p" "$tmp/field")" = 0 ] || fail "field --repair: the source is not at 0"; pass
expect_repaired_line "$pig_repaired"
run_ok "$tmp/path" path "$pig" --repair -g "$g" -s "v:$copy" -t "f:$at_copy:0.2:0.3:0.5"
expect_repaired_line "$pig_repaired"
run_ok "$tmp/expmap" expmap "$pig" --repair -g "$g" -s "v:$copy" -r 20
grep -q "^$copy 0 0\$" "$tmp/expmap" || fail "expmap --repair: the centre is not at (0, 0)"; pass
expect_repaired_line "$pig_repaired"
run_ok "$tmp/spline" spline "$pig" --repair -g "$g" -n 5 -c "f:$at_copy:0.6:0.2:0.2" \
  "f:$at_copy:0.2:0.6:0.2" "f:$at_copy:0.2:0.2:0.6" "f:$at_copy:0.4:0.3:0.3"
expect_repaired_line "$pig_repaired"
run_ok "$tmp/exact" exact "$pig" --repair -s "v:$copy" -t "f:$at_copy:0.2:0.3:0.5"
expect_repaired_line "$pig_repaired"
run_ok "$tmp/eval" eval "$pig" "$g" --repair --pairs 5 --fields 1 --paths 2
expect_repaired_line "$pig_repaired"
"$geoprox" render "$pig" --repair -g "$g" -s v:0 -o "$tmp/pig.png" --width 64 --height 64 \
  2>"$tmp/err" || fail "render --repair: $(cat "$tmp/err")"
expect_repaired_line "$pig_repaired"
run_ok "$tmp/refine" refine "$pig" --repair -o "$tmp/pig_refined.obj" --max-edge 1000
expect_repaired_line "$pig_repaired"
grep -qE '^ *input: 9085 vertices, 16848 faces' "$tmp/refine" || fail "refine --repair: $(cat "$tmp/refine")"; pass

# geoproxd with "repair": true: --check loads the mesh repaired, and the daemon serves the graph
# built with --repair as it is (no rebuild), with the same answers; remote field --out reads
# the local copy with --repair.
geoproxd=$(daemon_binary)
cat >"$tmp/config.json" <<JSON
{
  "bind": "127.0.0.1",
  "data_dir": "$root/data",
  "graph_dir": "$tmp/graphs",
  "compute_threads": 2,
  "log_level": "info",
  "meshes": [
    {"id": "pig", "mesh": "meshes/pig.stl", "repair": true, "samples": 300, "neighbors": 10}
  ]
}
JSON
"$geoproxd" --config "$tmp/config.json" --check >"$tmp/check" 2>"$tmp/err" ||
  fail "geoproxd --check: $(cat "$tmp/err")"
grep -qF "9085 vertices, 16848 faces; repaired: 421 vertices split (+443 copies))" "$tmp/check" ||
  fail "--check: $(cat "$tmp/check")"; pass
graph_before=$(cksum <"$g")
run_daemon "$tmp/config.json" pig 600
# 300 farthest-point samples, and the slit ends repair left as corner samples on top.
grep -q '^pig  *ready  *100% *16848  *[0-9]*$' "$tmp/meshes" || fail "pig not ready: $(cat "$tmp/meshes")"
samples=$(awk '$1 == "pig" { print $NF }' "$tmp/meshes")
[ "$samples" -ge 300 ] || fail "pig: $samples samples"; pass
grep -qF "mesh pig: repaired pig.stl: 421 vertices split (+443 copies)" "$tmp/daemon.log" ||
  fail "no repair line in the log: $(cat "$tmp/daemon.log")"; pass
grep -qF "graph $g mapped" "$tmp/daemon.log" || fail "the graph was not mapped as it is"; pass
[ "$(cksum <"$g")" = "$graph_before" ] || fail "the daemon rebuilt the graph"; pass
run_ok "$tmp/remote_info" remote info pig
grep -qx 'repair.vertices_split 421' "$tmp/remote_info" || fail "remote info: $(cat "$tmp/remote_info")"; pass
grep -qx 'repair.vertices_added 443' "$tmp/remote_info" || fail "remote info: $(cat "$tmp/remote_info")"; pass
grep -qx 'polygons -' "$tmp/remote_info" || fail "remote info: $(cat "$tmp/remote_info")"; pass
run_ok "$tmp/remote" remote distance pig "v:$copy" "f:$at_copy:0.2:0.3:0.5"
python3 - "$tmp/remote" "$tmp/d_repair" <<'PY' || fail "remote and offline --repair distances differ"
import sys
remote = open(sys.argv[1]).read().split("\n")[0].split()
offline = float(open(sys.argv[2]).read().split("\n")[1])
assert remote[0] == "distance", remote
assert abs(float(remote[1]) - offline) <= 1e-12, (remote, offline)
PY
pass
run_ok "$tmp/remote_field" remote field pig v:0 --mesh-file "$pig" --repair -o "$tmp/field.ply"
head -1 "$tmp/field.ply" | grep -qx ply || fail "remote field --out wrote no PLY"; pass
grep -qx 'element vertex 9085' "$tmp/field.ply" || fail "remote field --out: not 9085 vertices"; pass
expect_geoprox_error 2 "[NonManifoldVertex]" remote field pig v:0 --mesh-file "$pig" -o "$tmp/never.out"

echo "repair_flag_test.sh: $checks checks passed"
