#!/usr/bin/env python3
"""Interop test (ctest interop_jayson): geoproxd against jayson, an independent JSON-RPC 2.0
client library from npm (version pinned by package.json and package-lock.json beside this file).

    run_interop.py GEOPROXD SOURCE_DIR

1. Starts GEOPROXD on the shipped config (configs/default.json: spot and dragon; only its
   data_dir and graph_dir point at the repository's data/ and a temporary graph directory) with
   --port 0 --admin-port 0 --http-port P --port-file, P a port found free (--http-port 0 turns
   HTTP off: another P if it was taken meanwhile), and waits until every mesh is ready.
2. Asks the daemon, with the Python client (clients/python) over TCP, for mesh.list and a few
   geodesic.distance answers: the expected values, written to a JSON file.
3. Runs jayson.test.js under node's test runner with the daemon's TCP and HTTP ports and that
   file (GEOPROX_TCP_PORT, GEOPROX_HTTP_PORT, GEOPROX_EXPECTED); its exit status is the test's.
4. Stops the daemon with SIGTERM and asserts it exits 0.

Exits 77 (ctest's SKIP_RETURN_CODE) when tests/interop/node_modules is absent: scripts/install-deps
runs `npm ci` there.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SKIP = 77
HERE = Path(__file__).resolve().parent
# Queries whose answers jayson must get too: points in several forms, on both meshes.
QUERIES = [
    {"mesh": "spot", "source": "v:0", "target": "v:100"},
    {"mesh": "spot", "source": "v:0", "target": "f:100:0.2:0.3:0.5"},
    {"mesh": "spot", "source": {"edge": 7, "t": 0.25}, "target": "p:0.37,-0.29,0.19"},
    {"mesh": "dragon", "source": "v:0", "target": "v:5000"},
    {"mesh": "dragon", "source": "v:17", "target": "v:9999", "exact": True},
]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def fail(message: str) -> None:
    print(f"FAIL: {message}", file=sys.stderr)
    sys.exit(1)


def main() -> int:
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    geoproxd, source = sys.argv[1], Path(sys.argv[2]).resolve()
    if not (HERE / "node_modules" / "jayson").is_dir():
        print("SKIP: tests/interop/node_modules is absent (scripts/install-deps runs npm ci)")
        return SKIP
    sys.path.insert(0, str(source / "clients" / "python"))
    import geoprox

    with tempfile.TemporaryDirectory(prefix="geoprox-interop-") as tmp:
        root = Path(tmp)
        (root / "graphs").mkdir()
        config = json.loads((source / "configs" / "default.json").read_text())
        config["data_dir"] = str(source / "data")
        config["graph_dir"] = str(root / "graphs")
        config_path = root / "geoproxd.json"
        config_path.write_text(json.dumps(config, indent=2))
        port_file = root / "ports.json"
        log_path = root / "geoproxd.log"
        for attempt in range(3):
            with open(log_path, "wb") as log:
                daemon = subprocess.Popen(
                    [geoproxd, "--config", str(config_path), "--bind", "127.0.0.1",
                     "--port", "0", "--admin-port", "0", "--http-port", str(free_port()),
                     "--port-file", str(port_file)],
                    stdout=log, stderr=subprocess.STDOUT,
                    env={k: v for k, v in os.environ.items()
                         if k not in ("GEOPROX_ADMIN_TOKEN", "GEOPROX_QUERY_TOKEN")})
                try:
                    ports = wait_for_ports(daemon, port_file, log_path)
                    if ports is None and attempt < 2:
                        continue  # the free port was taken meanwhile: another one
                    if ports is None:
                        fail(f"geoproxd could not listen:\n{log_path.read_text()}")
                    status = run(ports, root, geoprox, log_path)
                finally:
                    if daemon.poll() is None:
                        daemon.send_signal(signal.SIGTERM)
                        try:
                            daemon.wait(timeout=30)
                        except subprocess.TimeoutExpired:
                            daemon.kill()
                            daemon.wait()
                break
        if daemon.returncode != 0:
            fail(f"geoproxd exited with status {daemon.returncode}:\n{log_path.read_text()}")
    return status


def wait_for_ports(daemon: subprocess.Popen, port_file: Path,
                   log_path: Path) -> "tuple[int, int] | None":
    """The daemon's TCP and HTTP ports from its port file; None if its HTTP port was in use."""
    deadline = time.monotonic() + 60
    while True:
        if daemon.poll() is not None:
            if "in use" in log_path.read_text():
                return None
            fail(f"geoproxd exited with status {daemon.returncode}:\n{log_path.read_text()}")
        try:
            ports = json.loads(port_file.read_text())
            return int(ports["port"]), int(ports["http_port"])
        except (OSError, ValueError, KeyError):
            if time.monotonic() > deadline:
                fail(f"geoproxd wrote no port file within 60 s:\n{log_path.read_text()}")
            time.sleep(0.02)


def run(ports: "tuple[int, int]", root: Path, geoprox, log_path: Path) -> int:
    tcp_port, http_port = ports

    with geoprox.Client("127.0.0.1", tcp_port, timeout=60) as client:
        meshes = client.wait_ready(timeout=300)
        expected = {
            "meshes": [
                {"id": m["id"], "vertices": m["vertices"], "faces": m["faces"]} for m in meshes
            ],
            "distances": [],
        }
        for params in QUERIES:
            result = client.call("geodesic.distance", params)
            expected["distances"].append(
                {"params": params, "distance": result["distance"],
                 "mesh_version": result["mesh_version"]})
    if sorted(m["id"] for m in expected["meshes"]) != ["dragon", "spot"]:
        fail(f"configs/default.json serves {expected['meshes']}, not spot and dragon")
    expected_path = root / "expected.json"
    expected_path.write_text(json.dumps(expected, indent=2))

    env = dict(os.environ, GEOPROX_TCP_PORT=str(tcp_port), GEOPROX_HTTP_PORT=str(http_port),
               GEOPROX_EXPECTED=str(expected_path))
    try:
        node = subprocess.run(["node", "--test", str(HERE / "jayson.test.js")], env=env,
                              cwd=HERE, timeout=300)
    except FileNotFoundError:
        fail("node is not installed, but tests/interop/node_modules is there")
    except subprocess.TimeoutExpired:
        fail("node --test jayson.test.js did not finish within 300 s")
    if node.returncode != 0:
        print(f"geoproxd log:\n{log_path.read_text()}", file=sys.stderr)
    return node.returncode


if __name__ == "__main__":
    sys.exit(main())
