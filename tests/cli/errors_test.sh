#!/usr/bin/env bash
# End-to-end test of how `geoprox` fails: every error is exactly one line on stderr,
# `geoprox: error: ...`, nothing on stdout, and the exit code documented in --help
# (1 usage, 2 input or output error). Also --help and --version.
# Usage: bash errors_test.sh GEOPROX_BINARY REPO_ROOT
set -euo pipefail
# shellcheck source=lib.sh
source "$(dirname "$0")/lib.sh"
cli_test_setup "$@"

# Every case: expect_geoprox_error_matching CODE PATTERN ARGS... (lib.sh): geoprox ARGS exits
# with CODE, prints nothing on stdout and exactly one line on stderr that starts with
# "geoprox: error: " and matches PATTERN (ERE).

mesh="$tmp/square.obj"
printf 'v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n' >"$mesh"
"$geoprox" exact "$mesh" --source v:0 >/dev/null || fail "the test mesh itself does not work"

# Usage errors: exit 1.
expect_geoprox_error_matching 1 'subcommand'
expect_geoprox_error_matching 1 'frobnicate' frobnicate
expect_geoprox_error_matching 1 'source' exact "$mesh"
expect_geoprox_error_matching 1 'MESH' info
expect_geoprox_error_matching 1 'radius' exact "$mesh" --source v:0 --radius -1
expect_geoprox_error_matching 1 'bogus' exact "$mesh" --source v:0 --bogus

# Missing and bad files: exit 2.
expect_geoprox_error_matching 2 'no-such-file\.obj' info "$tmp/no-such-file.obj"
expect_geoprox_error_matching 2 'no-such-file\.obj' exact "$tmp/no-such-file.obj" --source v:0
printf 'this is not a mesh\n' >"$tmp/garbage.xyz"
expect_geoprox_error_matching 2 'garbage\.xyz' info "$tmp/garbage.xyz"
: >"$tmp/empty.obj"
expect_geoprox_error_matching 2 '[Ee]mpty|no (faces|vertices)' info "$tmp/empty.obj"
# Polygons load triangulated, but not one whose corners all lie on a line.
printf 'v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nf 1 2 3 4\n' >"$tmp/line.obj"
expect_geoprox_error_matching 2 'line\.obj:5: face 0 \(vertices 0 1 2 3\).*one line.*DegenerateFaceIndices' \
  info "$tmp/line.obj"
printf 'v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n' >"$tmp/nan.obj"
expect_geoprox_error_matching 2 '[Nn]a[Nn]|finite' exact "$tmp/nan.obj" --source v:0

# Bad point syntax: exit 2, the message names the option and the text.
expect_geoprox_error_matching 2 'source.*x:1' exact "$mesh" --source x:1
expect_geoprox_error_matching 2 'source.*v:abc' exact "$mesh" --source v:abc
expect_geoprox_error_matching 2 'source.*f:1:0\.5' exact "$mesh" --source f:1:0.5
expect_geoprox_error_matching 2 'to.*e:0' exact "$mesh" --source v:0 --to e:0
expect_geoprox_error_matching 2 'source.*v:-1' exact "$mesh" --source v:-1
expect_geoprox_error_matching 2 'to' exact "$mesh" --source v:0 --to ''
# Syntax is checked before the mesh is read.
expect_geoprox_error_matching 2 'x:1' exact "$tmp/no-such-file.obj" --source x:1

# Ids out of range and bad coordinates: exit 2, the message names the id.
expect_geoprox_error_matching 2 'face 9999.*out of range|FaceOutOfRange' exact "$mesh" --source f:9999:0.2:0.3:0.5
expect_geoprox_error_matching 2 'vertex 4|VertexOutOfRange' exact "$mesh" --source v:4
expect_geoprox_error_matching 2 'edge 77|EdgeOutOfRange' exact "$mesh" --source v:0 --to e:77:0.5
expect_geoprox_error_matching 2 'BadBarycentric|barycentric' exact "$mesh" --source f:0:0.5:0.5:0.5
# Barycentrics rounded to six decimals (summing to 1.000001) are accepted and divided by their
# sum: the distance from corner 0 is that of the renormalised point.
expect_geoprox_ok "$tmp/rounded" exact "$mesh" --source f:0:0.576910:0.407899:0.015192 --to v:0
awk '$1 == "distance" {
  x = (0.407899 + 0.015192) / 1.000001; y = 0.015192 / 1.000001; d = $2 - sqrt(x * x + y * y)
  exit !(d < 1e-12 && d > -1e-12) }' "$tmp/rounded" ||
  fail "f:0:0.576910:0.407899:0.015192 is not the renormalised point: $(head -n 1 "$tmp/rounded")"
pass
expect_geoprox_error_matching 2 'BadEdgeParameter|parameter' exact "$mesh" --source e:0:1.5

# Output that cannot be written: exit 2, nothing created.
expect_geoprox_error_matching 2 'no-such-dir' exact "$mesh" --source v:0 --out "$tmp/no-such-dir/d.txt"
[ ! -e "$tmp/no-such-dir" ] || fail "--out into a missing directory created something"
expect_geoprox_error_matching 2 'out' exact "$mesh" --source v:0 --out ''
mkdir "$tmp/adir"
expect_geoprox_error_matching 2 'adir' exact "$mesh" --source v:0 --out "$tmp/adir"
[ -z "$(ls -A "$tmp/adir")" ] || fail "--out onto a directory left files: $(ls -A "$tmp/adir")"
checks=$((checks + 2))

# --help documents the exit codes; --version matches the project version.
"$geoprox" --help >"$tmp/help" 2>&1 || fail "geoprox --help exited non-zero"
grep -q 'Exit codes' "$tmp/help" || fail "geoprox --help does not document exit codes"
grep -q 'exact' "$tmp/help" && grep -q 'info' "$tmp/help" || fail "geoprox --help lists no subcommands"
"$geoprox" exact --help >"$tmp/help" 2>&1 || fail "geoprox exact --help exited non-zero"
grep -q -- '--source' "$tmp/help" && grep -q -- '--to' "$tmp/help" || fail "geoprox exact --help is incomplete"
want=$(sed -n 's/^project(geoprox VERSION \([0-9.]*\).*/\1/p' "$root/CMakeLists.txt")
[ -n "$want" ] || fail "cannot read the project version from $root/CMakeLists.txt"
got=$("$geoprox" --version) || fail "geoprox --version exited non-zero"
[ "$got" = "geoprox $want" ] || fail "geoprox --version printed '$got', expected 'geoprox $want'"
checks=$((checks + 3))

echo "errors_test.sh: $checks checks passed"
