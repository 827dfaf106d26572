#!/usr/bin/env bash
# End-to-end test of `geoprox remote ...` against a real geoproxd serving data/meshes/spot.obj:
# answers equal to the offline commands on the same graph file, --json/--csv output, and the
# error lines and exit codes (4 connection, 6 server error), and --token / GEOPROX_TOKEN against
# a daemon with a query token.
# Usage: bash remote_test.sh GEOPROX_BINARY REPO_ROOT
set -euo pipefail
# shellcheck source=lib.sh
source "$(dirname "$0")/lib.sh"
cli_test_setup "$@"

# A small graph, used by the offline commands and served by the daemon.
build_spot_graph
start_daemon
grep -q '^spot  *ready  *100% *5856  *200$' "$tmp/meshes" || fail "spot not ready: $(cat "$tmp/meshes")"; pass
head -1 "$tmp/meshes" | grep -q '^id  *state  *progress  *faces  *samples$' || fail "meshes header"; pass

# distance: equal to the offline answer on the same graph.
target=f:100:0.2:0.3:0.5
"$geoprox" remote distance spot v:0 "$target" >"$tmp/remote" 2>"$tmp/err" ||
  fail "remote distance: $(cat "$tmp/err")"
echo "v:0 $target" | "$geoprox" distance "$spot" --graph "$graph" --pairs - \
  >"$tmp/offline" 2>/dev/null || fail "offline distance failed"
sed -n 2p "$tmp/remote" | grep -qE '^exact (yes|no)$' || fail "no 'exact yes|no': $(cat "$tmp/remote")"; pass
python3 - "$tmp/remote" "$tmp/offline" <<'PY' || fail "remote and offline distances differ"
import sys
remote = open(sys.argv[1]).read().split("\n")[0].split()
offline = float(open(sys.argv[2]).read().split()[0])
assert remote[0] == "distance", remote
assert abs(float(remote[1]) - offline) <= 1e-12, (remote, offline)
PY
pass
# Host and port given as options instead of the environment.
env -u GEOPROX_HOST -u GEOPROX_PORT "$geoprox" remote distance spot v:0 "$target" \
  --host 127.0.0.1 --port "$port" --timeout-ms 5000 | cmp -s - "$tmp/remote" ||
  fail "--host/--port gave another answer"; pass

# path: starts with the distance, ends at the target.
"$geoprox" remote path spot v:0 "$target" >"$tmp/path" 2>"$tmp/err" ||
  fail "remote path: $(cat "$tmp/err")"
head -1 "$tmp/path" | grep -q '^distance ' || fail "path lacks its distance"; pass
[ "$(wc -l <"$tmp/path")" -ge 3 ] || fail "path has too few points: $(cat "$tmp/path")"; pass
python3 - "$tmp/path" <<'PY' || fail "path does not end at the target: $(tail -1 "$tmp/path")"
import sys
last = open(sys.argv[1]).read().split("\n")[-2].split()
face, *bary = last[0][2:].split(":")
assert face == "100", last
assert all(abs(float(b) - e) < 1e-9 for b, e in zip(bary, (0.2, 0.3, 0.5))), last
PY
pass

# field: one line per vertex; the source vertex at 0.
"$geoprox" remote field spot v:0 --csv >"$tmp/field" 2>"$tmp/err" || fail "remote field: $(cat "$tmp/err")"
[ "$(wc -l <"$tmp/field")" -eq 2930 ] || fail "field --csv: $(wc -l <"$tmp/field") lines"; pass
head -1 "$tmp/field" | grep -qx '0,0' || fail "field: vertex 0 is not at 0: $(head -1 "$tmp/field")"; pass
"$geoprox" remote field spot v:0 v:5 --cutoff 0.1 >"$tmp/field2" 2>"$tmp/err" ||
  fail "remote field with a cutoff: $(cat "$tmp/err")"
[ "$(wc -l <"$tmp/field2")" -eq 2930 ] || fail "field: not 2930 lines"; pass
grep -qx inf "$tmp/field2" || fail "field with a cutoff reaches everything"; pass

# matrix: 2 rows of 3.
"$geoprox" remote matrix spot --sources v:0 v:1 --targets v:2 v:3 "$target" >"$tmp/matrix" 2>"$tmp/err" ||
  fail "remote matrix: $(cat "$tmp/err")"
[ "$(wc -l <"$tmp/matrix")" -eq 2 ] || fail "matrix rows: $(cat "$tmp/matrix")"; pass
[ "$(awk '{print NF}' "$tmp/matrix" | sort -u)" = 3 ] || fail "matrix columns: $(cat "$tmp/matrix")"; pass
"$geoprox" remote matrix spot --sources v:0 v:1 --targets v:2 v:3 "$target" --csv | head -1 |
  grep -q '^[0-9.e+-]*,[0-9.e+-]*,[0-9.e+-]*$' || fail "matrix --csv"; pass

# health and info.
"$geoprox" remote health | grep -x 'status ok' >/dev/null || fail "health is not ok"; pass
"$geoprox" remote info | grep '^protocol_version 1$' >/dev/null || fail "info lacks protocol_version"; pass
"$geoprox" remote info spot | grep '^vertices 2930$' >/dev/null || fail "info spot lacks vertices"; pass

# --json: the raw result, valid JSON.
for command in "distance spot v:0 $target" "path spot v:0 $target" "field spot v:0" \
  "matrix spot --sources v:0 --targets v:1 v:2" meshes health info "info spot"; do
  # shellcheck disable=SC2086
  "$geoprox" remote $command --json >"$tmp/json" 2>"$tmp/err" || fail "$command --json: $(cat "$tmp/err")"
  python3 -c 'import json,sys; json.load(sys.stdin)' <"$tmp/json" || fail "$command --json is not JSON"
  pass
done
python3 -c 'import json,sys; r=json.load(sys.stdin); assert r["mesh"]=="spot" and r["distance"]>0' \
  < <("$geoprox" remote distance spot v:0 "$target" --json) || fail "distance --json content"; pass

# Errors: one line, the reason in brackets, distinct exit codes.
expect_geoprox_error 6 '[UnknownMesh]' remote distance nope v:0 v:1
expect_geoprox_error 6 '[FaceOutOfRange]' remote distance spot v:0 f:99999:1:0:0
expect_geoprox_error 6 '[BadPoint]' remote path spot v:0 zz
expect_geoprox_error 6 '[UnknownMesh]' remote info nope
# A closed port: take a free port from the kernel and close it again.
closed=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1]); s.close()')
expect_geoprox_error 4 '[ConnectionFailed]' remote meshes --port "$closed"
# A listener that never answers: the reply times out (exit 5).
python3 -c 'import socket,sys,time
s=socket.socket(); s.bind(("127.0.0.1",0)); s.listen(8)
open(sys.argv[1],"w").write(str(s.getsockname()[1])); time.sleep(20)' "$tmp/mute_port" &
helper_pid=$!
for _ in $(seq 50); do [ -s "$tmp/mute_port" ] && break; sleep 0.1; done
expect_geoprox_error 5 '[Timeout]' remote health --port "$(cat "$tmp/mute_port")" --timeout-ms 300
kill "$helper_pid" 2>/dev/null || true
wait "$helper_pid" 2>/dev/null || true
helper_pid=
# Usage errors stay exit 1.
set +e
"$geoprox" remote distance spot v:0 >/dev/null 2>&1; rc=$?
set -e
[ "$rc" -eq 1 ] || fail "missing TARGET: exit $rc (expected 1)"; pass
"$geoprox" remote --help | grep '6  remote: the daemon answered with an error' >/dev/null ||
  fail "--help lacks the exit codes"; pass

# SIGTERM: the daemon exits cleanly.
kill -TERM "$daemon_pid"
for _ in $(seq 100); do kill -0 "$daemon_pid" 2>/dev/null || break; sleep 0.1; done
kill -0 "$daemon_pid" 2>/dev/null && fail "geoproxd still running 10 s after SIGTERM"
wait "$daemon_pid" || fail "geoproxd exited with $? after SIGTERM"
daemon_pid=
pass

# Query token (docs/protocol.md, server.auth): a daemon given GEOPROX_QUERY_TOKEN refuses
# queries without it; --token or GEOPROX_TOKEN sends it; the token never reaches its log.
query_token=cli-query-token-3e9d61f0
rm -f "$tmp/port.json"
export GEOPROX_TOKEN=$query_token  # start_daemon's readiness check needs it
GEOPROX_QUERY_TOKEN=$query_token GEOPROX_LOG_LEVEL=debug start_daemon
grep -q '^spot  *ready' "$tmp/meshes" || fail "spot not ready with GEOPROX_TOKEN: $(cat "$tmp/meshes")"; pass
"$geoprox" remote distance spot v:0 "$target" | cmp -s - "$tmp/remote" ||
  fail "GEOPROX_TOKEN: another answer"; pass
unset GEOPROX_TOKEN
expect_geoprox_error 6 '[Unauthorized]' remote distance spot v:0 "$target"
expect_geoprox_error 6 '[Unauthorized]' remote meshes
expect_geoprox_error 6 '[Unauthorized]' remote distance spot v:0 "$target" --token wrong-token
"$geoprox" remote health | grep -x 'auth_required true' >/dev/null || fail "health without a token"; pass
"$geoprox" remote distance spot v:0 "$target" --token "$query_token" | cmp -s - "$tmp/remote" ||
  fail "--token: another answer"; pass
GEOPROX_TOKEN=wrong-token "$geoprox" remote distance spot v:0 "$target" --token "$query_token" |
  cmp -s - "$tmp/remote" || fail "--token does not override GEOPROX_TOKEN"; pass
GEOPROX_TOKEN=wrong-token "$geoprox" remote info >/dev/null 2>"$tmp/err" &&
  fail "a wrong GEOPROX_TOKEN was accepted"
grep -qF '[Unauthorized]' "$tmp/err" || fail "wrong GEOPROX_TOKEN: $(cat "$tmp/err")"; pass
kill -TERM "$daemon_pid"
wait "$daemon_pid" || fail "geoproxd (query token) exited with $? after SIGTERM"
daemon_pid=
grep -q 'server.auth refused' "$tmp/daemon.log" || fail "no refused server.auth in the log"; pass
grep -q 'method=geodesic.distance' "$tmp/daemon.log" || fail "no request lines at debug"; pass
grep -qF -e "$query_token" -e wrong-token "$tmp/daemon.log" && fail "a token is in the daemon's log"
pass

echo "remote_test.sh: $checks checks passed"
