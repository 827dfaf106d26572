#!/usr/bin/env bash
# End-to-end test of `geoprox exact` on generated flat meshes, where geodesic distance is the
# Euclidean distance: every vertex distance, vertex/edge/face/multiple sources, --radius, --out
# (atomic, same bytes as stdout), --to (distance, path, directions) and unreachable points.
# Usage: bash exact_test.sh GEOPROX_BINARY REPO_ROOT
set -euo pipefail
# shellcheck source=lib.sh
source "$(dirname "$0")/lib.sh"
cli_test_setup "$@"

# run CMD...: stdout -> $tmp/out, stderr -> $tmp/err, exit code -> $rc.
run() { set +e; "$@" >"$tmp/out" 2>"$tmp/err"; rc=$?; set -e; }
expect_success() {
  [ "$rc" -eq 0 ] || fail "$1: exit $rc, stderr: $(cat "$tmp/err")"
  pass
}

# A flat N x N grid of cells of size H on the tilted plane z = 0.3x - 0.2y (write_grid_obj in
# lib.sh: vertex and face numbering). Edge 0 is face 0's first side, from v:0 to v:1.
N=8
H=0.25
grid="$tmp/grid.obj"
write_grid_obj $N "$grid" $H 0.3 -0.2
nv=$(((N + 1) * (N + 1)))

# Position of a point given in geoprox syntax on the grid, as "x y z".
position() {
  awk -v n=$N -v h=$H -v p="$1" 'function vx(v) { return (v % (n + 1)) * h }
  function vy(v) { return int(v / (n + 1)) * h }
  BEGIN {
    k = split(p, f, ":")
    if (f[1] == "v") { x = vx(f[2]); y = vy(f[2]) }
    else if (f[1] == "e" && f[2] == 0) { x = f[3] * h; y = 0 }
    else if (f[1] == "f") {
      cell = int(f[2] / 2); i = cell % n; j = int(cell / n)
      a = j * (n + 1) + i; b = a + 1; c = b + n + 1; d = a + n + 1
      if (f[2] % 2 == 0) { v0 = a; v1 = b; v2 = c } else { v0 = a; v1 = c; v2 = d }
      x = f[3] * vx(v0) + f[4] * vx(v1) + f[5] * vx(v2)
      y = f[3] * vy(v0) + f[4] * vy(v1) + f[5] * vy(v2)
    } else { print "unsupported point " p > "/dev/stderr"; exit 1 }
    printf "%.17g %.17g %.17g\n", x, y, 0.3 * x - 0.2 * y
  }'
}

# check_distances FILE RADIUS "x y z"...: every line of FILE is vertex i's distance; it must be
# the Euclidean distance to the nearest source to 1e-9 relative, and inf beyond RADIUS.
check_distances() {
  local file=$1 radius=$2
  shift 2
  awk -v n=$N -v h=$H -v nv=$nv -v radius="$radius" -v srcs="$*" '
  BEGIN { ns = split(srcs, s, " ") / 3; bad = 0 }
  {
    v = NR - 1; x = (v % (n + 1)) * h; y = int(v / (n + 1)) * h; z = 0.3 * x - 0.2 * y
    e = -1
    for (k = 0; k < ns; k++) {
      d = sqrt((x - s[3*k+1])^2 + (y - s[3*k+2])^2 + (z - s[3*k+3])^2)
      if (e < 0 || d < e) e = d
    }
    if ($0 !~ /^(inf|[-+0-9.eE]+)$/) { printf "line %d: not a number: %s\n", NR, $0; bad++; next }
    if (radius != "inf" && e > radius * (1 + 1e-9)) {
      if ($1 != "inf") { printf "v:%d: expected inf beyond radius %s (distance %.17g), got %s\n", v, radius, e, $1; bad++ }
      next
    }
    if (radius != "inf" && e > radius * (1 - 1e-9) && $1 == "inf") next  # on the radius itself
    if ($1 == "inf") { printf "v:%d: got inf, expected %.17g\n", v, e; bad++; next }
    tol = 1e-9 * (e > h ? e : h)
    if ((($1 - e) > tol) || ((e - $1) > tol)) { printf "v:%d: got %s, expected %.17g\n", v, $1, e; bad++ }
  }
  END {
    if (NR != nv) { printf "%d lines, expected %d (one per vertex)\n", NR, nv; bad++ }
    exit bad > 0
  }' "$file" >"$tmp/check" || fail "distances in $file: $(head -5 "$tmp/check")"
  pass
}

# Vertex, edge, face and multiple sources, full surface.
for src in v:40 v:0 e:0:0.25 f:10:0.2:0.3:0.5 f:77:0.6:0.1:0.3; do
  run "$geoprox" exact "$grid" --source "$src"
  expect_success "exact --source $src"
  [ ! -s "$tmp/err" ] || fail "exact --source $src wrote to stderr: $(cat "$tmp/err")"
  check_distances "$tmp/out" inf "$(position "$src")"
done
run "$geoprox" exact "$grid" --source v:0 --source f:127:0.2:0.3:0.5
expect_success "exact with two sources"
check_distances "$tmp/out" inf "$(position v:0) $(position f:127:0.2:0.3:0.5)"

# --radius: distances inside are exact, vertices beyond print inf.
run "$geoprox" exact "$grid" --source v:40 --radius 0.6
expect_success "exact --radius 0.6"
check_distances "$tmp/out" 0.6 "$(position v:40)"
grep -qx inf "$tmp/out" || fail "--radius 0.6 left no vertex unreachable"
pass

# --out writes exactly what stdout shows, leaves no temporary file, and replaces a file whole.
run "$geoprox" exact "$grid" --source f:10:0.2:0.3:0.5
cp "$tmp/out" "$tmp/stdout.txt"
mkdir "$tmp/outdir"
run "$geoprox" exact "$grid" --source f:10:0.2:0.3:0.5 --out "$tmp/outdir/d.txt"
expect_success "exact --out"
[ ! -s "$tmp/out" ] || fail "--out also printed to stdout"
cmp -s "$tmp/stdout.txt" "$tmp/outdir/d.txt" || fail "--out file differs from stdout"
[ "$(ls -A "$tmp/outdir")" = "d.txt" ] || fail "--out left other files: $(ls -A "$tmp/outdir")"
pass
run "$geoprox" exact "$grid" --source v:3 --out "$tmp/outdir/d.txt"
expect_success "exact --out over an existing file"
check_distances "$tmp/outdir/d.txt" inf "$(position v:3)"
cp "$tmp/outdir/d.txt" "$tmp/before.txt"
run "$geoprox" exact "$grid" --source f:9999:0.2:0.3:0.5 --out "$tmp/outdir/d.txt"
[ "$rc" -ne 0 ] || fail "a failing run with --out exited 0"
cmp -s "$tmp/before.txt" "$tmp/outdir/d.txt" || fail "a failing run changed the --out file"
[ "$(ls -A "$tmp/outdir")" = "d.txt" ] || fail "a failing run left files: $(ls -A "$tmp/outdir")"
pass

# --to: distance, a path from the source to the target whose length is the distance, and two
# unit directions. Output format: see `geoprox exact --help`.
check_path() {
  local src=$1 dst=$2 file=$3
  awk -v s="$(position "$src")" -v t="$(position "$dst")" -v src="$src" -v h=$H '
  function fail(msg) { print msg; bad = 1; exit 1 }
  BEGIN { split(s, S, " "); split(t, T, " ")
          e = sqrt((S[1]-T[1])^2 + (S[2]-T[2])^2 + (S[3]-T[3])^2); tol = 1e-9 * (e > h ? e : h) }
  NR == 1 { if ($1 != "distance" || NF != 2) fail("line 1 is not \"distance D\": " $0)
            d = $2; if (d - e > tol || e - d > tol) fail("distance " d ", expected " e); next }
  NR == 2 { if ($1 != "path" || NF != 2 || $2 < 2) fail("line 2 is not \"path N\" with N >= 2: " $0)
            np = $2; next }
  NR <= 2 + np {
    if (NF != 4 || $1 !~ /^(v:[0-9]+|e:[0-9]+:[-+0-9.eE]+|f:[0-9]+:[-+0-9.eE]+:[-+0-9.eE]+:[-+0-9.eE]+)$/)
      fail("bad path line: " $0)
    if (NR == 3 && src ~ /^v:/ && $1 != src) fail("path starts at " $1 ", not at " src)
    if (NR > 3) len += sqrt(($2-px)^2 + ($3-py)^2 + ($4-pz)^2)
    if (NR == 3 && (($2-S[1])^2 + ($3-S[2])^2 + ($4-S[3])^2) > 1e-18) fail("path does not start at the source: " $0)
    px = $2; py = $3; pz = $4; next
  }
  NR == 3 + np || NR == 4 + np {
    want = NR == 3 + np ? "source_direction" : "target_direction"
    if ($1 != want || NF != 4 || $2 !~ /^[0-9]+$/) fail("expected \"" want " FACE X Y\": " $0)
    if (($3^2 + $4^2 - 1)^2 > 1e-18) fail(want " is not a unit vector: " $0)
    next
  }
  { fail("unexpected line " NR ": " $0) }
  END {
    if (bad) exit 1
    if (NR != 4 + np) { print "output has " NR " lines, expected " 4 + np; exit 1 }
    if (((px-T[1])^2 + (py-T[2])^2 + (pz-T[3])^2) > 1e-18) { print "path does not end at the target"; exit 1 }
    if (len - d > tol || d - len > tol) { printf "path length %.17g != distance %.17g\n", len, d; exit 1 }
  }' "$file" >"$tmp/check" || fail "--to $dst from $src: $(cat "$tmp/check")"
  pass
}
for pair in "v:0 v:80" "v:40 f:10:0.2:0.3:0.5" "f:77:0.6:0.1:0.3 e:0:0.25" "e:0:0.25 v:8"; do
  set -- $pair
  run "$geoprox" exact "$grid" --source "$1" --to "$2"
  expect_success "exact --source $1 --to $2"
  check_path "$1" "$2" "$tmp/out"
  run "$geoprox" exact "$grid" --source "$1" --to "$2" --out "$tmp/outdir/path.txt"
  expect_success "exact --to --out"
  check_path "$1" "$2" "$tmp/outdir/path.txt"
done
run "$geoprox" exact "$grid" --source v:5 --to v:5
expect_success "exact --to the source itself"
head -n 1 "$tmp/out" | grep -qx 'distance 0' || fail "distance from v:5 to itself: $(head -n 1 "$tmp/out")"
pass

# Two components: the other one is unreachable (inf), which is an answer (exit 0), not an error.
two="$tmp/two.obj"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 0 0\nv 6 0 0\nv 5 1 0\nf 1 2 3\nf 4 5 6\n' >"$two"
run "$geoprox" exact "$two" --source v:0
expect_success "exact on two components"
printf '0\n1\n1\ninf\ninf\ninf\n' | cmp -s - "$tmp/out" || fail "two components: got $(tr '\n' ' ' <"$tmp/out")"
pass
run "$geoprox" exact "$two" --source v:0 --to f:1:0.2:0.3:0.5
expect_success "exact --to an unreachable point"
printf 'distance inf\npath 0\n' | cmp -s - "$tmp/out" || fail "unreachable --to printed: $(cat "$tmp/out")"
[ "$(wc -l <"$tmp/err")" -eq 1 ] && grep -q unreachable "$tmp/err" ||
  fail "unreachable --to: expected one stderr line saying unreachable, got: $(cat "$tmp/err")"
pass

echo "exact_test.sh: $checks checks passed"
