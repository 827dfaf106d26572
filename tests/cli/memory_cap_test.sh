#!/usr/bin/env bash
# geoproxd under a fixed address-space cap (ulimit -v, 3 GiB) answers large requests of every
# query method (sizes that keep the test under half a minute), each with a result or a clear
# error (TooLarge, DeadlineExceeded, or ResourceExhausted where an answer would need more memory
# than its bound), and goes on serving: a small distance afterwards gives the same answer as
# before. Run by ctest with the geoprox binary and the repository root; skipped (exit 0, one
# line) in sanitizer builds, which reserve terabytes of address space.
set -euo pipefail
source "$(dirname "$0")/lib.sh"
cli_test_setup "$@"

if ldd "$geoprox" 2>/dev/null | grep -E 'libasan|libtsan' >/dev/null; then
  echo "SKIP ($test_name): an address-space cap does not combine with a sanitizer build"
  exit 0
fi
require_spot
build_spot_graph
ulimit -v $((3 << 20))  # KiB: the daemon and every client below
start_daemon

PYTHONPATH="$root/clients/python" python3 - "$port" >"$tmp/out" 2>&1 <<'EOF' ||
import sys
import time

import geoprox
from geoprox.errors import Reason, ServerError

client = geoprox.connect("127.0.0.1", int(sys.argv[1]), timeout=120)
before = client.distance("spot", "v:0", "f:100:0.2:0.3:0.5")["distance"]
info = client.server_info()
limits = info["limits"]
points = limits["max_points_per_request"]
vertices = 2930  # spot.obj
answered, refused = [], []
quick = 20000  # ms: what runs past it stops there (DeadlineExceeded), memory bounded on the way

def attempt(name, call):
    start = time.monotonic()
    try:
        call()
        answered.append(f"{name} ({time.monotonic() - start:.1f} s)")
    except ServerError as e:
        allowed = (Reason.TOO_LARGE, Reason.RESOURCE_EXHAUSTED, Reason.DEADLINE_EXCEEDED)
        assert e.reason in allowed, (name, e.reason, str(e))
        refused.append(f"{name}: {e.reason}")

side = min(points // 2, int(limits["max_matrix_pairs"] ** 0.5), 100)
every = [f"v:{v % vertices}" for v in range(side)]
attempt("matrix", lambda: client.matrix("spot", every, every, timeout_ms=quick))
sources = [f"v:{(7 * v) % vertices}" for v in range(min(limits["max_field_sources"], 300))]
attempt("field", lambda: client.field("spot", sources=sources, timeout_ms=quick))
attempt("expmap", lambda: client.call("geodesic.expmap", {"mesh": "spot", "source": "v:0",
                                                         "radius": 1e300, "timeout_ms": quick}))
control = [f"v:{v}" for v in (0, 1500, 2900, 700)]
for exact in (False, True):
    attempt(f"spline exact={exact}", lambda: client.call(
        "geodesic.spline", {"mesh": "spot", "control": control, "samples": min(points, 300),
                            "exact": exact, "timeout_ms": quick}))
attempt("path", lambda: client.path("spot", "v:0", "v:2900", timeout_ms=quick))
batch = [{"method": "geodesic.field", "params": {"mesh": "spot", "source": f"v:{v}"}}
         for v in range(min(points, limits["max_batch_requests"], 300))]
attempt("batch", lambda: client.call("batch", {"requests": batch, "timeout_ms": quick}))

after = client.distance("spot", "v:0", "f:100:0.2:0.3:0.5")["distance"]
assert after == before, (before, after)
assert client.health()["status"] == "ok"
print("answered:", ", ".join(answered))
print("refused:", "; ".join(refused) or "none")
EOF
  fail "requests under the cap: $(cat "$tmp/out")"
kill -0 "$daemon_pid" 2>/dev/null || fail "geoproxd died under the cap"
grep -q '^answered: ' "$tmp/out" || fail "no summary: $(cat "$tmp/out")"
pass
echo "memory_cap_test.sh: $checks checks passed ($(tr '\n' ' ' <"$tmp/out"))"
