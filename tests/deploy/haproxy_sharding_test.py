#!/usr/bin/env python3
"""Sharding by mesh: two groups of two geoproxd replicas behind HAProxy in HTTP mode, configured
from deploy/haproxy-shards.cfg and deploy/haproxy-meshes.map.

    haproxy_sharding_test.py GEOPROXD SOURCE_DIR

1. The map says which backend (shard) serves which mesh; each shard gets the meshes mapped to it
   (the shipped config's spot and dragon: one each). Every replica runs on a config of its own
   (configs/default.json with the shard's meshes, data from the repository, graphs in a
   temporary directory), on 127.0.0.1 with fixed free HTTP and admin ports. The first replica
   of each shard builds its meshes' graphs; the second maps those files: the test asserts the
   files were left untouched and both replicas serve the same mesh_version.
2. Reference answers: geodesic.distance over HTTP straight from the replicas, by POST and GET,
   the same object from both replicas of a shard. Each shard, asked directly for a mesh of the
   other, answers 404 UnknownMesh.
3. HAProxy (the Debian package) runs the shipped config with only the bind address and the four
   `server` addresses replaced (the test asserts no other line differs; the map is copied as
   is). GET /v1/meshes through it lists the default shard's meshes.
4. Six client threads (http.client, one keep-alive connection each, through HAProxy) send GET
   and POST distance requests for both meshes. Once 300 are answered, the replica that served
   the most of them is killed: from then until HAProxy marks it down every request is a POST;
   the replica is stopped (SIGSTOP) until HAProxy has sent it a request, then killed with
   SIGKILL, so that POSTs are in flight on it for sure. The load goes on for 3 s after the
   kill. The clients never retry: a request that fails (exception, non-200) is counted as lost.
5. Asserts: none lost; every answer is the reference object of its mesh and pair, the distance
   equal to the bit; the killed replica's shard answered after the kill and its survivor served
   more; no request through HAProxy reached a shard that does not serve its mesh (UnknownMesh
   counts of the replicas unchanged by the load); HAProxy (`show stat` on its master CLI)
   retried the POSTs left without a response on the killed replica, marked it down, and still
   has the other three up.

Bounded: a 240 s deadline for the whole test, 10 s per request; loopback only. Fails (does not
skip) when haproxy is not installed: scripts/install-deps installs it.
"""

from __future__ import annotations

import http.client
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
import urllib.parse
from pathlib import Path

THREADS = 6
PAIRS = 12               # distance queries per mesh
BEFORE_KILL = 300        # requests answered before the kill
AFTER_KILL_S = 3.0       # load after the kill: > the checks' 2 s to mark the replica down
AFTER_KILL_MIN = 300     # and at least this many requests
DEADLINE_S = 240.0
CFG = "deploy/haproxy-shards.cfg"
MAP = "deploy/haproxy-meshes.map"

started = time.monotonic()


def fail(message: str) -> None:
    print(f"FAIL: {message}", file=sys.stderr)
    sys.exit(1)


def remaining() -> float:
    left = DEADLINE_S - (time.monotonic() - started)
    if left <= 0:
        fail(f"deadline of {DEADLINE_S} s exceeded")
    return left


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def request(port: int, method: str, path: str, body: dict | None = None,
            timeout: float = 10) -> tuple[int, bytes]:
    """One request on a connection of its own."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout)
    try:
        data = None if body is None else json.dumps(body).encode()
        headers = {} if body is None else {"Content-Type": "application/json"}
        conn.request(method, path, body=data, headers=headers)
        response = conn.getresponse()
        return response.status, response.read()
    finally:
        conn.close()


def distance_request(mesh: str, pair: tuple[str, str], method: str) -> tuple[str, dict | None]:
    """(path, body) of geodesic.distance on `mesh`: GET with a query string, or POST."""
    source, target = pair
    if method == "GET":
        query = urllib.parse.urlencode({"source": source, "target": target})
        return f"/v1/meshes/{mesh}/distance?{query}", None
    return f"/v1/meshes/{mesh}/distance", {"source": source, "target": target}


class Replica:
    """One geoproxd on 127.0.0.1: ephemeral query port, fixed free HTTP and admin ports."""

    def __init__(self, binary: str, config: dict, root: Path, name: str) -> None:
        self.name = name
        self.config_path = root / f"{name}.json"
        self.config_path.write_text(json.dumps(config, indent=2))
        self.port_file = root / f"{name}.ports.json"
        self.log_path = root / f"{name}.log"
        self.log = open(self.log_path, "wb")
        self.http_port, self.admin_port = free_port(), free_port()
        self.process = subprocess.Popen(
            [binary, "--config", str(self.config_path), "--bind", "127.0.0.1", "--port", "0",
             "--admin-port", str(self.admin_port), "--http-port", str(self.http_port),
             "--port-file", str(self.port_file)],
            stdout=self.log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 60
        while True:
            if self.process.poll() is not None:
                fail(f"{name} exited with status {self.process.returncode}:\n{self.output()}")
            try:
                ports = json.loads(self.port_file.read_text())
                written = (int(ports["http_port"]), int(ports["admin_port"]))
                break
            except (OSError, ValueError, KeyError):
                if time.monotonic() > deadline:
                    fail(f"{name} wrote no port file within 60 s:\n{self.output()}")
                time.sleep(0.02)
        if written != (self.http_port, self.admin_port):
            fail(f"{name}: port file {ports}, expected http_port {self.http_port} and "
                 f"admin_port {self.admin_port}")

    def output(self) -> str:
        self.log.flush()
        return self.log_path.read_text(errors="replace")

    def wait_ready(self, meshes: list[str]) -> dict[str, str]:
        """Polls GET /v1/meshes until every mesh of the shard is ready: {id: mesh_version}."""
        deadline = time.monotonic() + min(120.0, remaining())
        last = "no answer"
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                fail(f"{self.name} exited with {self.process.returncode}:\n{self.output()}")
            try:
                status, body = request(self.http_port, "GET", "/v1/meshes")
                listed = json.loads(body)["meshes"] if status == 200 else []
                last = f"{status} {body[:200]!r}"
            except (OSError, http.client.HTTPException, ValueError) as e:
                listed, last = [], repr(e)
            if sorted(m["id"] for m in listed) not in ([], sorted(meshes)):
                fail(f"{self.name} lists {[m['id'] for m in listed]}, configured {meshes}")
            for m in listed:
                if m["state"] == "failed":
                    fail(f"{self.name}: mesh {m['id']} failed: {m['error']}")
            if listed and all(m["state"] == "ready" for m in listed):
                status, body = request(self.http_port, "GET", "/readyz")
                if status != 200:
                    fail(f"{self.name}: /readyz answered {status} {body!r} with every mesh ready")
                return {m["id"]: m["mesh_version"] for m in listed}
            time.sleep(0.05)
        fail(f"{self.name}: meshes {meshes} not ready within 120 s ({last}):\n{self.output()}")
        raise AssertionError  # unreachable

    def metric(self, name: str, **labels: str) -> float:
        """Sum of the samples of the Prometheus metric `name` whose labels include `labels`."""
        status, body = request(self.admin_port, "GET", "/metrics")
        if status != 200:
            fail(f"{self.name}: /metrics answered {status}")
        total = 0.0
        for line in body.decode().splitlines():
            m = re.match(rf"{re.escape(name)}(?:\{{(.*)\}})?\s+(\S+)$", line)
            if m is None:
                continue
            have = dict(re.findall(r'(\w+)="([^"]*)"', m.group(1) or ""))
            if all(have.get(k) == v for k, v in labels.items()):
                total += float(m.group(2))
        return total

    def http_served(self) -> float:
        return self.metric("geoprox_requests_total", transport="http")

    def unknown_mesh(self) -> float:
        return self.metric("geoprox_requests_total", transport="http", outcome="UnknownMesh")

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.log.close()


def parse_shards(cfg: str, mapping: str) -> tuple[dict[str, list[str]], dict[str, str], str]:
    """Backends and their server names, the map mesh -> backend, the default backend."""
    backends: dict[str, list[str]] = {}
    current = None
    for line in cfg.splitlines():
        if m := re.match(r"^(\w+)\s*(\S*)", line):
            current = m.group(2) if m.group(1) == "backend" else None
            if current:
                backends[current] = []
        elif current and (m := re.match(r"^\s+server\s+(\S+)\s", line)):
            backends[current].append(m.group(1))
    table = {}
    for line in mapping.splitlines():
        if line.strip() and not line.lstrip().startswith("#"):
            mesh, backend = line.split()
            table[mesh] = backend
    default = re.findall(r"^\s+default_backend\s+(\S+)\s*$", cfg, flags=re.M)
    if len(default) != 1:
        fail(f"{CFG}: expected one default_backend, found {default}")
    return backends, table, default[0]


def haproxy_config(deployed: str, bind_port: int, servers: dict[str, Replica]) -> str:
    """The shipped config with the bind address and the server addresses replaced."""
    text, count = re.subn(r"^(\s*bind\s+)0\.0\.0\.0:7880[ \t]*$", rf"\g<1>127.0.0.1:{bind_port}",
                          deployed, flags=re.M)
    if count != 1:
        fail(f"{CFG}: expected one 'bind 0.0.0.0:7880' line, found {count}")
    for name, r in servers.items():
        pattern = rf"^(\s*server\s+{name}\s+)geoproxd-{name}:7880(\s+check)[ \t]*$"
        text, count = re.subn(pattern, rf"\g<1>127.0.0.1:{r.http_port}\g<2>", text, flags=re.M)
        if count != 1:
            fail(f"{CFG}: expected one line 'server {name} geoproxd-{name}:7880 check', "
                 f"found {count}")
    changed = [(a, b) for a, b in zip(deployed.splitlines(), text.splitlines()) if a != b]
    if len(changed) != 1 + len(servers) or len(text.splitlines()) != len(deployed.splitlines()):
        fail(f"substitution changed {len(changed)} lines, expected {1 + len(servers)}")
    return text


def haproxy_stat(sock: Path) -> list[dict[str, str]]:
    """`show stat` of the worker, through the master CLI (-S): no line added to the config."""
    with socket.socket(socket.AF_UNIX) as s:
        s.settimeout(5)
        s.connect(str(sock))
        s.sendall(b"@1 show stat;quit\n")
        data = b""
        while chunk := s.recv(65536):
            data += chunk
    lines = [x for x in data.decode().splitlines() if x.strip()]
    if not lines or not lines[0].startswith("# "):
        fail(f"unexpected answer to 'show stat': {data[:300]!r}")
    header = lines[0][2:].split(",")
    return [dict(zip(header, x.split(","))) for x in lines[1:]]


def main() -> None:
    if len(sys.argv) != 3:
        fail("usage: haproxy_sharding_test.py GEOPROXD SOURCE_DIR")
    geoproxd, source = sys.argv[1], Path(sys.argv[2]).resolve()
    haproxy = shutil.which("haproxy") or shutil.which("haproxy", path="/usr/sbin:/sbin")
    if haproxy is None:
        fail("haproxy is not installed: this test runs a real HAProxy "
             "(scripts/install-deps installs the Debian package 'haproxy')")
    deployed = (source / CFG).read_text()
    mapping = (source / MAP).read_text()
    backends, table, default_backend = parse_shards(deployed, mapping)
    base = json.loads((source / "configs" / "default.json").read_text())
    mesh_ids = [m["id"] for m in base["meshes"]]
    if sorted(table) != sorted(mesh_ids):
        fail(f"{MAP} maps {sorted(table)}, the shipped config has {sorted(mesh_ids)}")
    if len(backends) != 2 or any(len(s) != 2 for s in backends.values()):
        fail(f"{CFG}: expected two backends of two servers, found {backends}")
    shards = {b: [m for m in mesh_ids if table[m] == b] for b in backends}
    if any(not meshes for meshes in shards.values()) or default_backend not in backends:
        fail(f"every backend needs a mesh of its own: {shards}, default {default_backend}")

    root = Path(tempfile.mkdtemp(prefix="geoprox-shards-"))
    replicas: dict[str, Replica] = {}   # server name -> replica
    shard_of: dict[str, str] = {}       # server name -> backend
    proxy = None
    try:
        def config(meshes: list[str]) -> dict:
            c = dict(base, data_dir=str(source / "data"), graph_dir=str(root / "graphs"))
            c["meshes"] = [m for m in base["meshes"] if m["id"] in meshes]
            return c

        # The first replica of each shard builds its graphs (both shards at once), the second
        # maps them.
        for backend, servers in backends.items():
            replicas[servers[0]] = Replica(geoproxd, config(shards[backend]), root, servers[0])
            shard_of[servers[0]] = backend
        versions = {}
        for backend, servers in backends.items():
            versions[servers[0]] = replicas[servers[0]].wait_ready(shards[backend])
        graphs = sorted((root / "graphs").glob("*.geoprox"))
        if len(graphs) != len(mesh_ids):
            fail(f"expected {len(mesh_ids)} graph files, found {[g.name for g in graphs]}")
        before = {g.name: (g.stat().st_ino, g.stat().st_mtime_ns) for g in graphs}
        for backend, servers in backends.items():
            replicas[servers[1]] = Replica(geoproxd, config(shards[backend]), root, servers[1])
            shard_of[servers[1]] = backend
        for backend, servers in backends.items():
            versions[servers[1]] = replicas[servers[1]].wait_ready(shards[backend])
            if versions[servers[1]] != versions[servers[0]]:
                fail(f"{backend}: replicas serve different graphs: {versions}")
        after = {g.name: (g.stat().st_ino, g.stat().st_mtime_ns) for g in graphs}
        if after != before:
            fail(f"second replicas rewrote the shared graph files: {before} -> {after}")
        setup_s = time.monotonic() - started

        # Reference answers straight from the replicas: POST and GET, both replicas of a shard.
        pairs = []
        for k in range(PAIRS):
            targets = [f"f:{(389 * k + 11) % 5800}:0.2:0.3:0.5", f"e:{(131 * k + 7) % 8000}:0.25",
                       f"v:{(577 * k + 1) % 2900}"]
            pairs.append((f"v:{(97 * k + 3) % 2900}", targets[k % 3]))
        reference: dict[tuple[str, int], dict] = {}
        for backend, servers in backends.items():
            for mesh in shards[backend]:
                for k, pair in enumerate(pairs):
                    answers = []
                    for server in servers:
                        for method in ("POST", "GET"):
                            status, body = request(replicas[server].http_port, method,
                                                   *distance_request(mesh, pair, method))
                            if status != 200:
                                fail(f"{server}: {method} {mesh} {pair}: {status} {body!r}")
                            answers.append(json.loads(body))
                    first = answers[0]
                    if any(a != first or a["distance"].hex() != first["distance"].hex()
                           for a in answers):
                        fail(f"{mesh} {pair}: replicas or methods disagree: {answers}")
                    if first["mesh"] != mesh or first["mesh_version"] != versions[servers[0]][mesh]:
                        fail(f"{mesh} {pair}: answer of another mesh or graph: {first}")
                    reference[(mesh, k)] = first
        distances = [r["distance"] for r in reference.values()]
        if len(set(distances)) < len(distances) // 2 or min(distances) <= 0:
            fail(f"reference distances do not tell answers apart: {distances}")

        # Each shard, asked directly for the other's meshes: 404 UnknownMesh.
        for backend, servers in backends.items():
            for server in servers:
                for mesh in (m for m in mesh_ids if m not in shards[backend]):
                    for method in ("GET", "POST"):
                        status, body = request(replicas[server].http_port, method,
                                               *distance_request(mesh, pairs[0], method))
                        reason = json.loads(body).get("error", {}).get("data", {}).get("reason")
                        if status != 404 or reason != "UnknownMesh":
                            fail(f"{server} asked for {mesh}: {status} {body!r}")

        # HAProxy: the shipped config, only addresses replaced; the map copied as is.
        proxy_port = free_port()
        proxy_cfg = root / "haproxy" / "haproxy-shards.cfg"
        proxy_cfg.parent.mkdir()
        proxy_cfg.write_text(haproxy_config(deployed, proxy_port, replicas))
        shutil.copyfile(source / MAP, proxy_cfg.parent / Path(MAP).name)
        check = subprocess.run([haproxy, "-c", "-f", str(proxy_cfg)], capture_output=True,
                               text=True, cwd=root)
        if check.returncode != 0:
            fail(f"haproxy -c refused the config:\n{check.stdout}{check.stderr}")
        master = root / "haproxy-master.sock"
        proxy_log_path = root / "haproxy.log"
        proxy_log = open(proxy_log_path, "wb")
        proxy = subprocess.Popen([haproxy, "-W", "-S", str(master), "-db", "-f", str(proxy_cfg)],
                                 stdout=proxy_log, stderr=subprocess.STDOUT, cwd=root)

        def proxy_output() -> str:
            proxy_log.flush()
            return proxy_log_path.read_text(errors="replace")

        deadline = time.monotonic() + min(30.0, remaining())
        while True:
            if proxy.poll() is not None:
                fail(f"haproxy exited with {proxy.returncode}:\n{proxy_output()}")
            try:
                status = {s["svname"]: s["status"] for s in haproxy_stat(master)
                          if s["svname"] in replicas}
                if status == {name: "UP" for name in replicas}:
                    break
            except OSError:
                status = "no master CLI yet"
            if time.monotonic() > deadline:
                fail(f"haproxy: servers not all up after 30 s: {status}\n{proxy_output()}")
            time.sleep(0.1)
        status, body = request(proxy_port, "GET", "/v1/meshes")
        listed = sorted(m["id"] for m in json.loads(body)["meshes"]) if status == 200 else None
        if listed != sorted(shards[default_backend]):
            fail(f"GET /v1/meshes through HAProxy: {status} {body[:300]!r}, expected the "
                 f"default shard's {shards[default_backend]}")
        unknown_before = {name: r.unknown_mesh() for name, r in replicas.items()}

        # Load through HAProxy, no client-side retry; kill the busiest replica mid-run.
        lock = threading.Lock()
        stop = threading.Event()
        post_only = threading.Event()   # around the kill: every request is a POST
        gets_in_flight = [0]
        killed_at: list[float] = []
        stats = {"sent": 0, "right": 0, "wrong": 0, "lost": 0}
        per_mesh_after_kill = {m: 0 for m in mesh_ids}
        errors: list[str] = []

        def worker(index: int) -> None:
            conn = http.client.HTTPConnection("127.0.0.1", proxy_port, timeout=10)
            n = index
            while not stop.is_set():
                mesh = mesh_ids[n % len(mesh_ids)]
                k = (n // len(mesh_ids)) % PAIRS
                method = ("GET", "POST")[(n // (len(mesh_ids) * PAIRS)) % 2]
                with lock:
                    if post_only.is_set():
                        method = "POST"
                    gets_in_flight[0] += method == "GET"
                    stats["sent"] += 1
                path, body = distance_request(mesh, pairs[k], method)
                after_kill = bool(killed_at)
                try:
                    data = None if body is None else json.dumps(body).encode()
                    headers = {} if body is None else {"Content-Type": "application/json"}
                    conn.request(method, path, body=data, headers=headers)
                    response = conn.getresponse()
                    status, reply = response.status, response.read()
                except (OSError, http.client.HTTPException) as e:
                    # Counted as lost, never sent again; the next request gets a new connection.
                    with lock:
                        gets_in_flight[0] -= method == "GET"
                        stats["lost"] += 1
                        errors.append(f"{method} {path}: {e!r}")
                    conn.close()
                    conn = http.client.HTTPConnection("127.0.0.1", proxy_port, timeout=10)
                    n += THREADS
                    continue
                expected = reference[(mesh, k)]
                try:
                    value = json.loads(reply) if status == 200 else None
                    right = (value == expected and
                             value["distance"].hex() == expected["distance"].hex())
                except (ValueError, KeyError, AttributeError):
                    right = False
                with lock:
                    gets_in_flight[0] -= method == "GET"
                    if status != 200:
                        stats["lost"] += 1
                        errors.append(f"{method} {path}: {status} {reply[:200]!r}")
                    elif right:
                        stats["right"] += 1
                        if after_kill:
                            per_mesh_after_kill[mesh] += 1
                    else:
                        stats["wrong"] += 1
                        errors.append(f"{method} {path}: {reply[:200]!r}, expected {expected}")
                n += THREADS
            conn.close()

        threads = [threading.Thread(target=worker, args=(i,)) for i in range(THREADS)]
        load_started = time.monotonic()
        served_before_load = {name: r.http_served() for name, r in replicas.items()}
        for t in threads:
            t.start()
        while True:
            with lock:
                done = stats["right"] + stats["wrong"] + stats["lost"]
            if done >= BEFORE_KILL or not any(t.is_alive() for t in threads):
                break
            remaining()
            time.sleep(0.005)
        served = {name: r.http_served() for name, r in replicas.items()}
        victim_name = max(served, key=lambda name: served[name] - served_before_load[name])
        victim = replicas[victim_name]
        victim_shard = shard_of[victim_name]
        unknown_victim = victim.unknown_mesh()
        # POST only from now until the victim is marked down; wait for the GETs under way.
        post_only.set()
        while True:
            with lock:
                if gets_in_flight[0] == 0:
                    break
            remaining()
            time.sleep(0.001)
        # Requests in flight on the victim at the kill, for sure: stop it, wait until HAProxy
        # has sent it some (stuck, unanswered), then kill it. They are POSTs.
        victim.process.send_signal(signal.SIGSTOP)
        stuck, stop_deadline = 0, time.monotonic() + 1.0
        while time.monotonic() < stop_deadline:
            stuck = next(int(x["scur"]) for x in haproxy_stat(master)
                         if (x["pxname"], x["svname"]) == (victim_shard, victim_name))
            if stuck >= 1:
                break
            time.sleep(0.002)
        victim.process.send_signal(signal.SIGKILL)
        victim.process.wait()
        killed_at.append(time.monotonic())
        with lock:
            done_at_kill = stats["right"] + stats["wrong"] + stats["lost"]
        marked_down = None
        while True:
            with lock:
                done = stats["right"] + stats["wrong"] + stats["lost"]
            if marked_down is None and any(
                    x["status"].startswith("DOWN") for x in haproxy_stat(master)
                    if (x["pxname"], x["svname"]) == (victim_shard, victim_name)):
                marked_down = time.monotonic() - killed_at[0]
                post_only.clear()
            if (time.monotonic() - killed_at[0] >= AFTER_KILL_S
                    and done - done_at_kill >= AFTER_KILL_MIN):
                break
            if not any(t.is_alive() for t in threads):
                break
            remaining()
            time.sleep(0.01)
        stop.set()
        for t in threads:
            t.join(timeout=min(30.0, remaining()))
        if any(t.is_alive() for t in threads):
            fail(f"load did not stop within 30 s: {stats}")
        load_s = time.monotonic() - load_started
        survivors = {name: r for name, r in replicas.items() if r is not victim}
        served_after = {name: r.http_served() for name, r in survivors.items()}
        unknown_after = {name: r.unknown_mesh() for name, r in survivors.items()}
        stat = haproxy_stat(master)
        rows = {(s["pxname"], s["svname"]): s for s in stat}
        partner = next(n for n in backends[victim_shard] if n != victim_name)

        print(f"shards {shards}; default {default_backend}; setup {setup_s:.1f} s")
        print(f"replicas (HTTP ports): "
              f"{ {name: r.http_port for name, r in replicas.items()} }; HAProxy {proxy_port}")
        print(f"requests served before the kill: {served}")
        print(f"killed {victim_name} of {victim_shard} (SIGSTOP, then SIGKILL with {stuck} "
              f"POST requests in flight on it) after {done_at_kill} requests; HAProxy marked it "
              f"down {marked_down if marked_down is None else round(marked_down, 2)} s later")
        print(f"sent {stats['sent']}, right {stats['right']}, wrong {stats['wrong']}, "
              f"lost {stats['lost']} in {load_s:.1f} s; right answers started after the kill, "
              f"by mesh: {per_mesh_after_kill}")
        print(f"survivors served {served_after} in all")
        for (px, sv), s in sorted(rows.items()):
            if sv in replicas or (px in backends and sv == "BACKEND"):
                print(f"haproxy {px}/{sv}: status {s['status']}, retries {s['wretr']}, "
                      f"redispatches {s['wredis']}, connection errors {s['econ']}, "
                      f"response errors {s['eresp']}, 2xx {s['hrsp_2xx']}, "
                      f"4xx {s['hrsp_4xx']}, 5xx {s['hrsp_5xx']}")
        for e in errors[:10]:
            print(e, file=sys.stderr)

        if stats["lost"] or stats["wrong"]:
            fail(f"{stats['lost']} requests failed through HAProxy, {stats['wrong']} answers "
                 f"differ from the reference")
        if stats["right"] != stats["sent"] or done_at_kill < BEFORE_KILL:
            fail(f"not every request was answered: {stats}")
        if min(per_mesh_after_kill.values()) < 1:
            fail(f"a mesh got no answer after the kill: {per_mesh_after_kill}")
        if served_after[partner] <= served[partner]:
            fail(f"{partner}, the survivor of {victim_shard}, answered nothing after the kill")
        moved = {n: unknown_after[n] - unknown_before[n] for n in survivors}
        if any(moved.values()) or unknown_victim != unknown_before[victim_name]:
            fail(f"requests through HAProxy reached a shard without their mesh "
                 f"(UnknownMesh answers during the load: {moved}, "
                 f"{victim_name} {unknown_victim - unknown_before[victim_name]})")
        if stuck < 1:
            fail(f"no request reached {victim_name} within 1 s of SIGSTOP: {served}")
        victim_row = rows[(victim_shard, victim_name)]
        # wretr counts the L7 retries (a request sent, no response); the refused connections
        # retried on the other replica count as redispatches (wredis).
        if int(victim_row["wretr"] or 0) < 1:
            fail(f"HAProxy did not retry the POSTs in flight on {victim_name}: {victim_row}")
        down = {sv: rows[(shard_of[sv], sv)]["status"] for sv in replicas}
        if not down[victim_name].startswith("DOWN") or any(
                s != "UP" for sv, s in down.items() if sv != victim_name):
            fail(f"HAProxy server states after the kill: {down}")
        if f"Server {victim_shard}/{victim_name} is DOWN" not in proxy_output():
            fail(f"HAProxy did not log {victim_name} DOWN:\n{proxy_output()}")
        print(f"haproxy sharding: 1 passed, 0 failed ({time.monotonic() - started:.1f} s)")
    finally:
        if proxy is not None:
            proxy.terminate()
            try:
                proxy.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proxy.kill()
                proxy.wait()
        for r in replicas.values():
            r.stop()
        if os.environ.get("GEOPROX_KEEP_TEST_DIR"):
            print(f"kept {root}")
        else:
            shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
