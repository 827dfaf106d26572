#!/usr/bin/env python3
"""Soak: geoproxd under mixed load with bad requests for a minute; nothing lost, no leak.

    soak_test.py GEOPROXD LOAD_GENERATOR SOURCE_DIR [--duration S] [--warmup S]
                 [--sanitized ON|OFF] [--http]

1. geoproxd starts on a temporary copy of configs/default.json serving data/meshes/spot.obj
   (its graph is built at start into a temporary directory; the test waits for mesh.list to
   say ready), on ephemeral query and admin ports of 127.0.0.1, log level "warn".
2. bench/load_generator runs against it: 64 connections, 8 requests in flight each (closed
   loop), mix distance/path/field/matrix, 5% bad requests of nine kinds (each must get its
   expected error reason, a notification none), --daemon-pid sampling the daemon's VmRSS when
   the warmup ends, every 5 s and at the end; --json writes its summary.
3. Asserts: the generator exits 0 (no request lost or unanswered after its drain period, no
   unexpected or repeated reply, no good request failed, every bad request got its reason, no
   connection dropped, daemon alive); at least 1,000 requests answered and every bad kind sent
   and answered as expected; the daemon is still running and answers server.health "ok"; RSS at
   the end <= RSS at the start + max(16 MiB, 10% of the start). A leak of one reply per request
   would add tens to hundreds of MiB in a minute (over 100,000 requests; a field reply is 16 KiB
   on spot); the daemon's legitimate growth after the warmup (per-thread scratch, allocator
   arenas, the 64 connections' buffers) was 0 to 2 MiB in the runs measured for
   docs/reliability.md. Finally SIGTERM: the daemon must drain and exit 0.

--http (ctest server.soak_http): the same over the daemon's HTTP port (on an ephemeral port of
127.0.0.1): the generator's --http, keep-alive connections pipelining 8 requests each, the HTTP
bad kinds (no missing-id or notification there; a mesh in the body instead, and each must also
get its status); at the end GET /healthz must answer 200 "ok" too.

Under AddressSanitizer (--sanitized ON, passed by tests/CMakeLists.txt from GEOPROX_SANITIZE or
GEOPROX_TSAN) RSS measures the sanitizer's quarantine and shadow memory, not the daemon's own
allocations, so the memory bound alone is skipped (with a printed reason); everything else is
checked. ctest gives a shorter --duration there (the instrumented daemon is several times
slower, and the suite runs twice per CI job). docs/reliability.md, "Load and soak", has figures.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

CONNECTIONS = 64
DEPTH = 8
BAD_FRACTION = 0.05
MIX = "distance=0.4,path=0.3,field=0.15,matrix=0.15"
RSS_SLACK_KIB = 16 * 1024  # the fixed part of the memory bound
RSS_SLACK_FRACTION = 0.10  # the proportional part
MIN_ANSWERED = 1000
BAD_KINDS = {  # load_generator's bad kinds and the reason each must get ("" = no reply)
    "malformed-json": "ParseError", "unknown-method": "UnknownMethod",
    "unknown-mesh": "UnknownMesh", "face-out-of-range": "FaceOutOfRange",
    "bary-off-simplex": "BadBarycentric", "nan-coordinate": "ParseError",
    "wrong-type": "BadPoint", "missing-id": "InvalidRequest", "notification": "",
}
HTTP_BAD_KINDS = {  # the same over HTTP (load_generator --http; the status is checked there)
    "malformed-json": "ParseError", "unknown-method": "NotFound",
    "unknown-mesh": "UnknownMesh", "face-out-of-range": "FaceOutOfRange",
    "bary-off-simplex": "BadBarycentric", "nan-coordinate": "ParseError",
    "wrong-type": "BadPoint", "mesh-in-body": "InvalidParams",
}


def fail(message: str) -> None:
    print(f"FAIL: {message}", file=sys.stderr)
    sys.exit(1)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def call(port: int, method: str, params: dict | None = None, timeout: float = 10) -> dict:
    """One request on a fresh connection; returns the reply object."""
    request = {"jsonrpc": "2.0", "id": 1, "method": method}
    if params is not None:
        request["params"] = params
    with socket.create_connection(("127.0.0.1", port), timeout=timeout) as s:
        s.sendall((json.dumps(request) + "\n").encode())
        data = b""
        while not data.endswith(b"\n"):
            chunk = s.recv(65536)
            if not chunk:
                raise OSError(f"{method}: connection closed before the reply")
            data += chunk
    return json.loads(data)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("geoproxd")
    parser.add_argument("load_generator")
    parser.add_argument("source")
    parser.add_argument("--duration", type=float, default=60)
    parser.add_argument("--warmup", type=float, default=3)
    parser.add_argument("--sanitized", default="OFF")
    parser.add_argument("--http", action="store_true")
    args = parser.parse_args()
    source = Path(args.source).resolve()
    sanitized = args.sanitized.upper() in ("ON", "1", "TRUE", "YES")

    root = Path(tempfile.mkdtemp(prefix="geoprox-soak-"))
    daemon = None
    log = None
    try:
        config = json.loads((source / "configs" / "default.json").read_text())
        config["data_dir"] = str(source / "data")
        config["graph_dir"] = str(root / "graphs")
        config["log_level"] = "warn"
        config["meshes"] = [m for m in config["meshes"] if m["id"] == "spot"]
        if len(config["meshes"]) != 1:
            fail("configs/default.json no longer serves the mesh 'spot'")
        limits = config["limits"]
        # The generator treats Overloaded as a failure: make sure the shipped limits leave room
        # for every request it keeps in flight.
        if CONNECTIONS * DEPTH > limits["max_queue"] or DEPTH > limits["max_inflight_per_connection"] \
                or CONNECTIONS >= limits["max_connections"]:
            fail(f"the shipped limits cannot hold {CONNECTIONS} x {DEPTH} requests: {limits}")
        config_path = root / "geoproxd.json"
        config_path.write_text(json.dumps(config, indent=2))

        port_file = root / "ports.json"
        log_path = root / "geoproxd.log"
        log = open(log_path, "wb")
        daemon_command = [args.geoproxd, "--config", str(config_path), "--bind", "127.0.0.1",
                          "--port", "0", "--admin-port", str(free_port()),
                          "--port-file", str(port_file)]
        # --http-port 0 turns HTTP off; a free port when the soak runs over HTTP.
        daemon_command += ["--http-port", str(free_port()) if args.http else "0"]
        daemon = subprocess.Popen(daemon_command, stdout=log, stderr=subprocess.STDOUT)

        def daemon_output() -> str:
            log.flush()
            return log_path.read_text(errors="replace")[-4000:]

        started = time.monotonic()
        while True:
            if daemon.poll() is not None:
                fail(f"geoproxd exited with {daemon.returncode}:\n{daemon_output()}")
            try:
                ports = json.loads(port_file.read_text())
                port = int(ports["port"])
                http_port = int(ports["http_port"]) if args.http else None
                break
            except (OSError, ValueError, KeyError):
                if time.monotonic() - started > 60:
                    fail(f"geoproxd wrote no port file within 60 s:\n{daemon_output()}")
                time.sleep(0.02)
        while True:  # the graph of spot is built at start
            meshes = call(port, "mesh.list")["result"]["meshes"]
            states = {m["id"]: m["state"] for m in meshes}
            if states == {"spot": "ready"}:
                break
            if "failed" in states.values() or daemon.poll() is not None:
                fail(f"mesh.list: {meshes}\n{daemon_output()}")
            if time.monotonic() - started > 300:
                fail(f"spot not ready after 300 s: {meshes}")
            time.sleep(0.2)
        print(f"geoproxd pid {daemon.pid} on 127.0.0.1:{port}"
              f"{f' (HTTP {http_port})' if args.http else ''}, spot ready after "
              f"{time.monotonic() - started:.1f} s")

        summary_path = root / "summary.json"
        command = [args.load_generator, "--port", str(http_port if args.http else port),
                   *(["--http"] if args.http else []), "--mesh", "spot",
                   "--connections", str(CONNECTIONS), "--depth", str(DEPTH),
                   "--duration", str(args.duration), "--warmup", str(args.warmup),
                   "--drain", "20", "--mix", MIX, "--bad", str(BAD_FRACTION),
                   "--daemon-pid", str(daemon.pid), "--rss-every", "5",
                   "--json", str(summary_path)]
        print("$ " + " ".join(command), flush=True)
        run = subprocess.run(command, timeout=args.duration + args.warmup + 120)
        try:
            summary = json.loads(summary_path.read_text())
        except (OSError, ValueError) as e:
            fail(f"load_generator exited with {run.returncode} and wrote no summary ({e})")

        problems = []
        if run.returncode != 0:
            problems.append(f"load_generator exited with {run.returncode}: {summary['failures']}")
        for key in ("lost", "unexpected_replies", "connections_dropped"):
            if summary[key] != 0:
                problems.append(f"{key}: {summary[key]}")
        if summary["unexpected_errors"] or summary["wrong_replies"]:
            problems.append(f"unexpected errors {summary['unexpected_errors']}, wrong replies "
                            f"{summary['wrong_replies']}")
        if summary["answered"] != summary["sent"]:
            problems.append(f"{summary['sent']} sent, {summary['answered']} answered")
        if summary["answered"] < MIN_ANSWERED:
            problems.append(f"only {summary['answered']} requests answered: the load proved little")
        for kind, reason in (HTTP_BAD_KINDS if args.http else BAD_KINDS).items():
            if summary["sent_by_kind"].get(f"bad:{kind}", 0) == 0:
                problems.append(f"no bad request of kind {kind} was sent")
            elif reason and summary["expected_errors"].get(reason, 0) == 0:
                problems.append(f"no {reason} came back for the bad kind {kind}")
        for method in ("distance", "path", "field", "matrix"):
            if summary["sent_by_kind"].get(method, 0) == 0:
                problems.append(f"no {method} request was sent")

        if daemon.poll() is not None:
            problems.append(f"geoproxd exited during the load with {daemon.returncode}")
        else:
            health = call(port, "server.health").get("result", {})
            if health.get("status") != "ok":
                problems.append(f"server.health after the load: {health}")
            if args.http:
                try:
                    with urllib.request.urlopen(f"http://127.0.0.1:{http_port}/healthz",
                                                timeout=10) as response:
                        body = response.read().decode(errors="replace").strip()
                        if response.status != 200 or body != "ok":
                            problems.append(f"GET /healthz after the load: {response.status} "
                                            f"{body!r}")
                except OSError as e:
                    problems.append(f"GET /healthz after the load: {e}")

        memory = summary["memory"]
        start, end, peak = memory["start_kib"], memory["end_kib"], memory["max_kib"]
        bound = None
        if start is None or end is None:
            problems.append(f"no memory figures: {memory}")
        else:
            bound = start + max(RSS_SLACK_KIB, int(RSS_SLACK_FRACTION * start))
            print(f"daemon RSS: start {start} KiB, end {end} KiB ({end - start:+d} KiB), "
                  f"max {peak} KiB; bound {bound} KiB")
            if sanitized:
                print("memory bound not checked: this is a sanitizer build, whose RSS is the "
                      "allocator's quarantine and shadow memory rather than the daemon's own")
            elif end > bound:
                problems.append(f"daemon RSS grew from {start} to {end} KiB, over the bound "
                                f"of {bound} KiB (start + max(16 MiB, 10%))")

        if daemon.poll() is None:
            daemon.send_signal(signal.SIGTERM)
            try:
                status = daemon.wait(timeout=30)
            except subprocess.TimeoutExpired:
                status = None
                problems.append("geoproxd did not exit within 30 s of SIGTERM")
            if status is not None and status != 0:
                problems.append(f"geoproxd exited with {status} after SIGTERM")

        if problems:
            fail("; ".join(problems) + f"\ngeoproxd log (tail):\n{daemon_output()}")
        print(f"soak: {summary['answered']} requests answered in {args.duration:g} s "
              f"({summary['throughput_rps']:.0f}/s), none lost; soak passed")
    finally:
        if daemon is not None and daemon.poll() is None:
            daemon.kill()
            daemon.wait()
        if log is not None:
            log.close()
        if os.environ.get("GEOPROX_KEEP_TEST_DIR"):
            print(f"kept {root}")
        else:
            shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
