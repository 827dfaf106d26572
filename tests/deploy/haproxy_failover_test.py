#!/usr/bin/env python3
"""Scale-out end to end: three geoproxd replicas behind HAProxy configured from deploy/haproxy.cfg.

    haproxy_failover_test.py GEOPROXD SOURCE_DIR

1. Replica 1 starts on the shipped config (configs/default.json; only its data_dir and graph_dir
   point at the repository's data/ and a temporary graph directory) and builds the graphs of
   every mesh. Replicas 2 and 3 then start on the same config and map those graph files: the
   test asserts the files were left untouched and all three serve the same mesh_version.
2. HAProxy (the Debian package) runs deploy/haproxy.cfg with only the frontend's bind address and
   the three `server` addresses and check ports replaced (the test asserts no other line differs).
3. Eight client threads (the Python client, one connection each, through HAProxy) send a fixed
   number of geodesic.distance requests whose answers are known from replica 1 directly. When a
   third is done, the replica with the most client connections is killed with SIGKILL. A request
   that fails (connection lost, timeout, retryable server error) is sent again, at most 8 times.
4. Asserts: every request was answered, every answer equals the reference value, the kill hit
   live traffic (at least one request failed and was retried), and both survivors answered.

Bounded: 2400 requests, at most 8 attempts each, a 300 s deadline for the whole test; loopback
only. Fails (does not skip) when haproxy is not installed: scripts/install-deps installs it.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REQUESTS = 2400
THREADS = 8
MAX_ATTEMPTS = 8
DEADLINE_S = 300.0


def fail(message: str) -> None:
    print(f"FAIL: {message}", file=sys.stderr)
    sys.exit(1)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Replica:
    """One geoproxd on ephemeral query and admin ports of 127.0.0.1."""

    def __init__(self, binary: str, config: Path, root: Path, name: str) -> None:
        self.name = name
        self.port_file = root / f"{name}.ports.json"
        self.log_path = root / f"{name}.log"
        self.log = open(self.log_path, "wb")
        self.process = subprocess.Popen(
            [binary, "--config", str(config), "--bind", "127.0.0.1", "--port", "0",
             "--admin-port", str(free_port()), "--http-port", "0",
             "--port-file", str(self.port_file)],
            stdout=self.log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 60
        while True:
            if self.process.poll() is not None:
                fail(f"{name} exited with status {self.process.returncode}:\n{self.output()}")
            try:
                ports = json.loads(self.port_file.read_text())
                self.port, self.admin_port = int(ports["port"]), int(ports["admin_port"])
                break
            except (OSError, ValueError, KeyError):
                if time.monotonic() > deadline:
                    fail(f"{name} wrote no port file within 60 s:\n{self.output()}")
                time.sleep(0.02)

    def output(self) -> str:
        self.log.flush()
        return self.log_path.read_text(errors="replace")

    def admin_get(self, path: str) -> tuple[int, str]:
        """GET on the admin port (plain HTTP/1.0: no proxy settings get in the way)."""
        with socket.create_connection(("127.0.0.1", self.admin_port), timeout=5) as s:
            s.sendall(f"GET {path} HTTP/1.0\r\nHost: localhost\r\n\r\n".encode())
            data = b""
            while chunk := s.recv(65536):
                data += chunk
        head, _, body = data.decode(errors="replace").partition("\r\n\r\n")
        return int(head.split(" ", 2)[1]), body

    def metric(self, name: str) -> float:
        """Sum of every sample of the Prometheus metric `name` (any labels)."""
        _, text = self.admin_get("/metrics")
        total = 0.0
        for line in text.splitlines():
            if re.match(rf"{re.escape(name)}(\{{|\s)", line):
                total += float(line.rsplit(" ", 1)[1])
        return total

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.log.close()


def haproxy_config(deployed: str, bind_port: int, replicas: list[Replica]) -> str:
    """deploy/haproxy.cfg with the bind address and the server addresses/check ports replaced."""
    text, count = re.subn(r"^(\s*bind\s+)0\.0\.0\.0:7878[ \t]*$", rf"\g<1>127.0.0.1:{bind_port}",
                          deployed, flags=re.M)
    if count != 1:
        fail(f"deploy/haproxy.cfg: expected one 'bind 0.0.0.0:7878' line, found {count}")
    for i, r in enumerate(replicas, start=1):
        pattern = rf"^(\s*server\s+geoproxd-{i}\s+)geoproxd-{i}:7878(\s+check\s+port\s+)7879[ \t]*$"
        text, count = re.subn(pattern, rf"\g<1>127.0.0.1:{r.port}\g<2>{r.admin_port}", text,
                              flags=re.M)
        if count != 1:
            fail(f"deploy/haproxy.cfg: expected one line 'server geoproxd-{i} geoproxd-{i}:7878 "
                 f"check port 7879', found {count}")
    extra = re.findall(r"^\s*server\s+.*$", text, flags=re.M)
    if len(extra) != len(replicas):
        fail(f"deploy/haproxy.cfg has {len(extra)} server lines, the test runs {len(replicas)}")
    changed = [(a, b) for a, b in zip(deployed.splitlines(), text.splitlines()) if a != b]
    if len(changed) != 1 + len(replicas):
        fail(f"substitution changed {len(changed)} lines, expected {1 + len(replicas)}")
    return text


def main() -> None:
    if len(sys.argv) != 3:
        fail("usage: haproxy_failover_test.py GEOPROXD SOURCE_DIR")
    geoproxd, source = sys.argv[1], Path(sys.argv[2]).resolve()
    sys.path.insert(0, str(source / "clients" / "python"))
    import geoprox  # noqa: E402  (the in-tree client)

    haproxy = shutil.which("haproxy") or shutil.which("haproxy", path="/usr/sbin:/sbin")
    if haproxy is None:
        fail("haproxy is not installed: this test runs a real HAProxy "
             "(scripts/install-deps installs the Debian package 'haproxy')")
    started = time.monotonic()
    root = Path(tempfile.mkdtemp(prefix="geoprox-deploy-"))
    replicas: list[Replica] = []
    proxy = None
    try:
        # The shipped config, with its paths made absolute: data from the repository, graphs in
        # a directory of our own (never the source tree's var/).
        config = json.loads((source / "configs" / "default.json").read_text())
        config["data_dir"] = str(source / "data")
        config["graph_dir"] = str(root / "graphs")
        config_path = root / "geoproxd.json"
        config_path.write_text(json.dumps(config, indent=2))
        mesh_ids = [m["id"] for m in config["meshes"]]

        replicas.append(Replica(geoproxd, config_path, root, "geoproxd-1"))
        with geoprox.Client("127.0.0.1", replicas[0].port, timeout=30) as c:
            c.wait_ready(timeout=240)  # builds every graph once
        graphs = sorted((root / "graphs").glob("*.geoprox"))
        if len(graphs) != len(mesh_ids):
            fail(f"expected {len(mesh_ids)} graph files, found {[g.name for g in graphs]}")
        before = {g.name: (g.stat().st_ino, g.stat().st_mtime_ns) for g in graphs}

        for i in (2, 3):  # these map the graphs built by replica 1
            replicas.append(Replica(geoproxd, config_path, root, f"geoproxd-{i}"))
        versions = []
        for r in replicas:
            with geoprox.Client("127.0.0.1", r.port, timeout=30) as c:
                entries = c.wait_ready(timeout=120)
            versions.append({e["id"]: e["mesh_version"] for e in entries})
            status, body = r.admin_get("/readyz")
            if status != 200:
                fail(f"{r.name}: /readyz answered {status} {body!r} with every mesh ready")
        after = {g.name: (g.stat().st_ino, g.stat().st_mtime_ns) for g in graphs}
        if after != before:
            fail(f"replicas 2 and 3 rewrote the shared graph files: {before} -> {after}")
        if any(v != versions[0] for v in versions):
            fail(f"replicas serve different graphs: {versions}")

        # Reference answers straight from replica 1.
        pairs = []
        for k in range(30):
            mesh = mesh_ids[k % len(mesh_ids)]
            pairs.append((mesh, f"v:{(97 * k) % 2900}", f"f:{(389 * k + 11) % 5800}:0.2:0.3:0.5"))
        with geoprox.Client("127.0.0.1", replicas[0].port, timeout=30) as c:
            reference = [c.distance(*p)["distance"] for p in pairs]
        if len(set(reference)) < len(pairs) // 2:
            fail(f"reference distances are not varied enough to tell answers apart: {reference}")

        deployed = (source / "deploy" / "haproxy.cfg").read_text()
        proxy_port = free_port()
        proxy_cfg = root / "haproxy.cfg"
        proxy_cfg.write_text(haproxy_config(deployed, proxy_port, replicas))
        check = subprocess.run([haproxy, "-c", "-f", str(proxy_cfg)], capture_output=True,
                               text=True)
        if check.returncode != 0:
            fail(f"haproxy -c refused the config:\n{check.stdout}{check.stderr}")
        proxy_log = open(root / "haproxy.log", "wb")
        proxy = subprocess.Popen([haproxy, "-db", "-f", str(proxy_cfg)], stdout=proxy_log,
                                 stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 30
        while True:
            if proxy.poll() is not None:
                proxy_log.flush()
                fail(f"haproxy exited with {proxy.returncode}:\n"
                     f"{(root / 'haproxy.log').read_text(errors='replace')}")
            try:
                socket.create_connection(("127.0.0.1", proxy_port), timeout=1).close()
                break
            except OSError:
                if time.monotonic() > deadline:
                    fail("haproxy is not listening after 30 s")
                time.sleep(0.05)
        with geoprox.Client("127.0.0.1", proxy_port, timeout=10, connect=False) as c:
            c.wait_ready(timeout=30)

        # Load through HAProxy; kill the busiest replica a third of the way through.
        lock = threading.Lock()
        stats = {"sent": 0, "answered": 0, "right": 0, "wrong": 0, "retried": 0, "lost": 0}
        errors: list[str] = []

        def worker(index: int) -> None:
            client = geoprox.Client("127.0.0.1", proxy_port, timeout=10, connect=False)
            try:
                for n in range(index, REQUESTS, THREADS):
                    k = n % len(pairs)
                    with lock:
                        stats["sent"] += 1
                    for attempt in range(MAX_ATTEMPTS):
                        try:
                            value = client.distance(*pairs[k])["distance"]
                        except geoprox.GeoproxError as e:
                            if not e.retryable or attempt + 1 == MAX_ATTEMPTS:
                                with lock:
                                    stats["lost"] += 1
                                    errors.append(f"request {n}: {e.reason}: {e}")
                                break
                            with lock:
                                stats["retried"] += 1
                            time.sleep(0.05 * 2**attempt)
                            continue
                        with lock:
                            stats["answered"] += 1
                            stats["right" if value == reference[k] else "wrong"] += 1
                            if value != reference[k]:
                                errors.append(f"request {n}: {pairs[k]} -> {value}, "
                                              f"expected {reference[k]}")
                        break
            finally:
                client.close()

        threads = [threading.Thread(target=worker, args=(i,)) for i in range(THREADS)]
        for t in threads:
            t.start()
        while True:
            with lock:
                done = stats["answered"] + stats["lost"]
            if done >= REQUESTS // 3 or not any(t.is_alive() for t in threads):
                break
            time.sleep(0.005)
        connections = [r.metric("geoprox_connections") for r in replicas]
        served = [r.metric("geoprox_requests_total") for r in replicas]
        victim = replicas[connections.index(max(connections))]
        victim.process.send_signal(signal.SIGKILL)
        victim.process.wait()
        with lock:
            done_at_kill = stats["answered"] + stats["lost"]
        for t in threads:
            t.join(timeout=max(1.0, DEADLINE_S - (time.monotonic() - started)))
        if any(t.is_alive() for t in threads):
            fail(f"load did not finish within {DEADLINE_S} s: {stats}")
        survivors = [r for r in replicas if r is not victim]
        served_after = [r.metric("geoprox_requests_total") for r in survivors]

        print(f"replicas: query ports {[r.port for r in replicas]}, admin ports "
              f"{[r.admin_port for r in replicas]}; HAProxy on 127.0.0.1:{proxy_port}")
        print(f"before the kill: client connections per replica {connections}, "
              f"requests served {served}")
        print(f"killed {victim.name} (SIGKILL) after {done_at_kill} of {REQUESTS} requests")
        print(f"sent {stats['sent']}, answered {stats['answered']} "
              f"({stats['right']} right, {stats['wrong']} wrong), failed attempts retried "
              f"{stats['retried']}, lost {stats['lost']}")
        print(f"survivors {[r.name for r in survivors]} served {served_after} requests in all")
        for e in errors[:10]:
            print(e, file=sys.stderr)
        if stats["sent"] != REQUESTS or stats["answered"] != REQUESTS:
            fail(f"{REQUESTS} requests to send, {stats['sent']} sent, {stats['answered']} answered")
        if stats["right"] != REQUESTS or stats["wrong"] != 0:
            fail(f"{stats['wrong']} answers differ from the reference values")
        if done_at_kill >= REQUESTS:
            fail("the load finished before the kill: the test proved nothing")
        if max(connections) < 1:
            fail(f"no replica had a client connection at the kill: {connections}")
        if stats["retried"] < 1:
            fail("no request failed when a replica with live connections was killed")
        if min(served_after[i] - served[replicas.index(r)] for i, r in enumerate(survivors)) <= 0:
            fail(f"a survivor answered nothing after the kill: {served} -> {served_after}")
        print("haproxy failover: 1 passed, 0 failed")
    finally:
        if proxy is not None:
            proxy.terminate()
            try:
                proxy.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proxy.kill()
                proxy.wait()
        for r in replicas:
            r.stop()
        if os.environ.get("GEOPROX_KEEP_TEST_DIR"):
            print(f"kept {root}")
        else:
            shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
