# shellcheck shell=bash
# Helpers shared by the end-to-end tests of `geoprox` (tests/cli/*_test.sh). Sourced, not run:
# the name does not end in _test.sh, so ctest does not take it for a test. Each script starts
#   set -euo pipefail
#   source "$(dirname "$0")/lib.sh"
#   cli_test_setup "$@"

# cli_test_setup GEOPROX_BINARY REPO_ROOT: the common prelude. Sets geoprox and root (a usage
# error when either is missing, or when REPO_ROOT is no checkout), tmp (a fresh directory, removed
# at exit with the daemon and helper process if any are running), checks=0, daemon_pid and
# helper_pid (empty). After it, fail and pass work.
cli_test_setup() {
  test_name=$(basename "$0")
  geoprox=${1:?usage: $test_name GEOPROX_BINARY REPO_ROOT}
  root=${2:?usage: $test_name GEOPROX_BINARY REPO_ROOT}
  tmp=$(mktemp -d)
  daemon_pid=
  helper_pid=  # a background process of the test itself (not the daemon), killed at exit
  trap cli_test_cleanup EXIT
  checks=0
  [ -d "$root/docs" ] || fail "no repository at $root"
}

cli_test_cleanup() {
  if [ -n "$helper_pid" ]; then kill "$helper_pid" 2>/dev/null || true; fi
  if [ -n "$daemon_pid" ] && kill -0 "$daemon_pid" 2>/dev/null; then
    kill -TERM "$daemon_pid" 2>/dev/null || true
    wait "$daemon_pid" 2>/dev/null || true
  fi
  rm -rf "$tmp"
}

# fail MESSAGE...: prints "FAIL (NAME_test.sh): MESSAGE" (and the end of the daemon's log when
# one was started) and exits 1.
fail() {
  echo "FAIL ($test_name): $*" >&2
  if [ -f "$tmp/daemon.log" ]; then tail -5 "$tmp/daemon.log" >&2; fi
  exit 1
}

# pass: counts one check that held.
pass() { checks=$((checks + 1)); }

# require_spot: sets spot to the shipped sample mesh, data/meshes/spot.obj; fails if it is missing.
require_spot() {
  spot="$root/data/meshes/spot.obj"
  [ -f "$spot" ] || fail "sample mesh $spot is missing"
}

# write_long_faced_strip_obj FILE: a flat 10 x 1 strip as OBJ (long_faced_strip of
# tests/core/test_meshes.h): a 10 x 10 grid of 0.1 cells on [0, 1]^2, then eleven long faces out
# to x = 10 fanning from (10, 0) and (10, 1), with no vertex inside. With every vertex a sample
# (what a default build takes) the long faces' middles are 4.5139 from all of them.
write_long_faced_strip_obj() {
  awk 'BEGIN {
    for (j = 0; j <= 10; ++j) for (i = 0; i <= 10; ++i) printf "v %g %g 0\n", i / 10, j / 10
    print "v 10 0 0"; print "v 10 1 0"
    for (j = 0; j < 10; ++j) for (i = 0; i < 10; ++i) {
      a = j * 11 + i + 1; b = a + 1; c = a + 12; d = a + 11
      if ((i + j) % 2) { print "f", a, b, d; print "f", b, c, d } else { print "f", a, b, c; print "f", a, c, d }
    }
    for (j = 0; j < 10; ++j) print "f", j * 11 + 11, 122, j * 11 + 22
    print "f", 121, 122, 123
  }' >"$1"
}

# write_grid_obj N FILE [H [SX SY]]: a flat N x N grid of square cells of side H (default 1) on
# the plane z = SX x + SY y (default z = 0), as OBJ. Vertex (i, j) is at (i H, j H) and has id
# j (N+1) + i; cell (i, j) (cell id j N + i) has faces 2c = (a, b, c) and 2c+1 = (a, c, d) with
# a = (i, j), b = (i+1, j), c = (i+1, j+1), d = (i, j+1).
write_grid_obj() {
  awk -v n="$1" -v h="${3:-1}" -v sx="${4:-0}" -v sy="${5:-0}" 'BEGIN {
    for (j = 0; j <= n; j++) for (i = 0; i <= n; i++)
      printf "v %.17g %.17g %.17g\n", i * h, j * h, sx * i * h + sy * j * h
    for (j = 0; j < n; j++) for (i = 0; i < n; i++) {
      a = j * (n + 1) + i + 1; b = a + 1; c = b + n + 1; d = a + n + 1
      printf "f %d %d %d\nf %d %d %d\n", a, b, c, a, c, d
    }
  }' >"$2"
}

# build_spot_graph: the graph of spot.obj (--samples 200 --neighbors 12) in
# $tmp/graphs/spot.geoprox, which start_daemon serves; sets spot and graph.
build_spot_graph() {
  require_spot
  graph="$tmp/graphs/spot.geoprox"
  mkdir -p "$tmp/graphs"
  "$geoprox" build "$spot" -o "$graph" --samples 200 --neighbors 12 -q >/dev/null 2>"$tmp/err" ||
    fail "build failed: $(cat "$tmp/err")"
}

# daemon_binary: the geoproxd built next to geoprox (fails the test when it is missing).
daemon_binary() {
  local geoproxd
  geoproxd="$(cd "$(dirname "$geoprox")/../../server" && pwd)/geoproxd"
  [ -x "$geoproxd" ] || fail "daemon $geoproxd is missing (build the geoproxd target)"
  echo "$geoproxd"
}

# run_daemon CONFIG MESH TRIES: geoproxd on CONFIG, on ephemeral ports of 127.0.0.1, logging to
# $tmp/daemon.log. Sets daemon_pid and port, exports GEOPROX_HOST and GEOPROX_PORT, and waits
# for the port file (10 s at most) and for `geoprox remote meshes` to list MESH as ready (TRIES
# tenths of a second at most); the last listing is left in $tmp/meshes. The daemon is stopped
# at exit unless the test stops it and clears daemon_pid.
run_daemon() {
  local config=$1 mesh=$2 tries=$3 geoproxd
  geoproxd=$(daemon_binary)
  "$geoproxd" --config "$config" --port 0 --admin-port 0 --http-port 0 \
    --port-file "$tmp/port.json" \
    >"$tmp/daemon.log" 2>&1 &
  daemon_pid=$!
  for _ in $(seq 100); do
    [ -s "$tmp/port.json" ] && break
    kill -0 "$daemon_pid" 2>/dev/null || fail "geoproxd exited at start"
    sleep 0.1
  done
  [ -s "$tmp/port.json" ] || fail "geoproxd wrote no port file"
  port=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["port"])' "$tmp/port.json")
  export GEOPROX_HOST=127.0.0.1 GEOPROX_PORT=$port
  for _ in $(seq "$tries"); do
    "$geoprox" remote meshes >"$tmp/meshes" 2>/dev/null && grep -q "^$mesh  *ready" "$tmp/meshes" &&
      break
    sleep 0.1
  done
}

# start_daemon: run_daemon serving spot.obj as mesh "spot" from the graph of build_spot_graph.
start_daemon() {
  cat >"$tmp/config.json" <<JSON
{
  "bind": "127.0.0.1",
  "data_dir": "$root/data",
  "graph_dir": "$tmp/graphs",
  "compute_threads": 2,
  "log_level": "warn",
  "meshes": [
    {"id": "spot", "mesh": "meshes/spot.obj", "graph": "$graph", "samples": 200, "neighbors": 12}
  ]
}
JSON
  run_daemon "$tmp/config.json" spot 100
}

# expect_geoprox_ok OUT ARGS...: `geoprox ARGS` exits 0, prints something on stdout (kept in
# OUT) and nothing on stderr. Counts no check: the caller checks what OUT says.
expect_geoprox_ok() {
  local out=$1
  shift
  set +e
  "$geoprox" "$@" >"$out" 2>"$tmp/err"
  local rc=$?
  set -e
  [ "$rc" -eq 0 ] || fail "geoprox $*: exit $rc: $(cat "$tmp/err")"
  [ ! -s "$tmp/err" ] || fail "geoprox $* wrote to stderr: $(cat "$tmp/err")"
  [ -s "$out" ] || fail "geoprox $* printed nothing"
}

# expect_geoprox_error CODE TEXT ARGS...: `geoprox ARGS` exits with CODE and prints exactly one
# line on stderr, starting 'geoprox: error: ' and containing TEXT (a fixed string); nothing on
# stdout, and no $tmp/never.out (the output file the failing commands are given). Counts a check.
expect_geoprox_error() { check_geoprox_error -F "$@"; }

# expect_geoprox_error_matching CODE PATTERN ARGS...: the same, the line matching PATTERN (ERE).
expect_geoprox_error_matching() { check_geoprox_error -E "$@"; }

check_geoprox_error() {  # -F|-E CODE PATTERN ARGS...
  local mode=$1 code=$2 pattern=$3
  shift 3
  set +e
  "$geoprox" "$@" >"$tmp/out" 2>"$tmp/err"
  local rc=$?
  set -e
  [ "$rc" -eq "$code" ] || fail "$*: exit $rc (expected $code): $(cat "$tmp/err")"
  [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "$*: not one line on stderr: $(cat "$tmp/err")"
  grep -q '^geoprox: error: ' "$tmp/err" || fail "$*: no 'geoprox: error:' prefix: $(cat "$tmp/err")"
  grep -q "$mode" -- "$pattern" "$tmp/err" || fail "$*: expected $pattern, got: $(cat "$tmp/err")"
  [ ! -s "$tmp/out" ] || fail "$*: wrote to stdout: $(head -c 300 "$tmp/out")"
  [ ! -e "$tmp/never.out" ] || fail "$*: wrote its output file"
  pass
}
