#!/usr/bin/env python3
"""HTTP against TCP on one daemon: closed-loop distance throughput, then latency at half load.

    bench/transport_throughput.py --build build-release --mesh-file MESH [--rounds 3]
                                  [--duration 10] [--concurrency 128] [--out FILE]

Starts geoproxd (BUILD/server/geoproxd) serving MESH alone, waits until its graph is ready,
then runs bench/load_generator in interleaved rounds, so that both transports see the same
machine load:
  1. closed loop, `--concurrency` requests in flight: TCP as 16 connections pipelining
     concurrency/16 each, HTTP as `--concurrency` keep-alive connections with one each;
  2. open loop at half the median HTTP throughput (Poisson arrivals) over HTTP, and at the same
     rate over TCP.
Distances between random face points (the load generator's default). Prints a Markdown
report: each round's figures, the medians, and HTTP/TCP; --out writes it to FILE too.
"""

from __future__ import annotations

import argparse
import json
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run_load(generator: Path, args: list[str], out: Path) -> dict:
    subprocess.run([str(generator), *args, "--json", str(out)], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return json.loads(out.read_text())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build", type=Path, required=True)
    parser.add_argument("--mesh-file", type=Path, required=True)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--duration", type=float, default=10)
    parser.add_argument("--concurrency", type=int, default=128)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    geoproxd = args.build / "server/geoproxd"
    generator = args.build / "bench/load_generator"
    mesh = args.mesh_file.resolve()
    connections = 16
    depth = max(1, args.concurrency // connections)

    with tempfile.TemporaryDirectory(prefix="geoprox-transport-") as tmp:
        root = Path(tmp)
        tcp_port, http_port = free_port(), free_port()
        config = {"bind": "127.0.0.1", "port": tcp_port, "admin_port": 0, "http_port": http_port,
                  "data_dir": str(mesh.parent), "graph_dir": str(root / "graphs"),
                  "log_level": "warn", "meshes": [{"id": "bench", "mesh": mesh.name}]}
        (root / "config.json").write_text(json.dumps(config))
        daemon = subprocess.Popen([str(geoproxd), "--config", str(root / "config.json")],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            deadline = time.monotonic() + 600
            while True:
                try:
                    with urllib.request.urlopen(f"http://127.0.0.1:{http_port}/readyz",
                                                timeout=2) as r:
                        if r.status == 200:
                            break
                except OSError:
                    pass
                if time.monotonic() > deadline or daemon.poll() is not None:
                    print("geoproxd did not get ready", file=sys.stderr)
                    return 1
                time.sleep(1)

            common = ["--mesh", "bench", "--duration", str(args.duration), "--warmup", "1"]
            tcp_closed = ["--port", str(tcp_port), "--connections", str(connections),
                          "--depth", str(depth)]
            http_closed = ["--http", "--port", str(http_port), "--connections",
                           str(args.concurrency)]
            rows = []
            throughput = {"tcp": [], "http": []}
            for i in range(args.rounds):
                for name, flags in (("tcp", tcp_closed), ("http", http_closed)):
                    r = run_load(generator, common + flags, root / f"{name}-{i}.json")
                    throughput[name].append(r["throughput_rps"])
                    rows.append(f"| closed | {name} | {i + 1} | {r['throughput_rps']:.0f} | "
                                f"{r['latency_ms']['p50']:.2f} | {r['latency_ms']['p99']:.2f} |")
            http_rps = statistics.median(throughput["http"])
            tcp_rps = statistics.median(throughput["tcp"])
            half = http_rps / 2
            p99 = {"tcp": [], "http": []}
            for i in range(args.rounds):
                for name, flags in (("tcp", tcp_closed), ("http", http_closed)):
                    r = run_load(generator, common + flags + ["--rate", f"{half:.0f}",
                                                              "--arrivals", "poisson"],
                                 root / f"{name}-half-{i}.json")
                    p99[name].append(r["latency_ms"]["p99"])
                    rows.append(f"| half | {name} | {i + 1} | {r['throughput_rps']:.0f} | "
                                f"{r['latency_ms']['p50']:.2f} | {r['latency_ms']['p99']:.2f} |")
        finally:
            daemon.terminate()
            daemon.wait(timeout=30)

    report = [
        f"Mesh {mesh.name}; {args.rounds} interleaved rounds of {args.duration:g} s; "
        f"{args.concurrency} requests in flight (TCP: {connections} connections x {depth}, "
        f"HTTP: {args.concurrency} keep-alive connections x 1); half load: {half:.0f} req/s, "
        "Poisson arrivals.",
        "",
        "| load | transport | round | req/s | p50 ms | p99 ms |",
        "|---|---|---|---|---|---|",
        *rows,
        "",
        f"- closed-loop throughput, medians: TCP {tcp_rps:.0f} req/s, HTTP {http_rps:.0f} req/s, "
        f"HTTP/TCP {http_rps / tcp_rps:.2f}",
        f"- p99 at half load, medians: HTTP {statistics.median(p99['http']):.2f} ms, "
        f"TCP {statistics.median(p99['tcp']):.2f} ms",
    ]
    text = "\n".join(report) + "\n"
    print(text, end="")
    if args.out:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
