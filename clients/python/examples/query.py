#!/usr/bin/env python3
"""Queries a running geoproxd with the geoprox Python client.

    python3 clients/python/examples/query.py [--host HOST] [--port PORT] [--mesh MESH]

The address defaults to GEOPROX_HOST / GEOPROX_PORT, else 127.0.0.1:7878; the mesh to "spot"
(configs/default.json serves it). Run from anywhere: the package is found next to this file
when it is not installed.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # clients/python, if not installed

import geoprox  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--host", default=None, help="daemon address (default GEOPROX_HOST or 127.0.0.1)"
    )
    parser.add_argument(
        "--port", type=int, default=None, help="query port (default GEOPROX_PORT or 7878)"
    )
    parser.add_argument("--mesh", default="spot", help="mesh id (default spot)")
    args = parser.parse_args()
    mesh = args.mesh

    try:
        with geoprox.Client(args.host, args.port, timeout=30) as client:
            info = client.server_info()
            print(f"server {info['server_version']}, protocol {info['protocol_version']}")
            (entry,) = client.wait_ready(mesh, timeout=120)  # its graph may still be building
            print(
                f"mesh {mesh}: {entry['vertices']} vertices, {entry['faces']} faces, "
                f"{entry['samples']} samples"
            )

            # Points: the command-line strings or the helpers, mixed freely.
            source, target = "v:0", geoprox.face(100, 0.2, 0.3, 0.5)
            d = client.distance(mesh, source, target)
            print(f"distance {source} -> {geoprox.format_point(target)}: {d['distance']:.6f}")
            exact = client.distance(mesh, "v:0", "v:1500", exact=True)
            approx = client.distance(mesh, "v:0", "v:1500")
            print(f"v:0 -> v:1500: graph {approx['distance']:.6f}, exact {exact['distance']:.6f}")

            path = client.path(mesh, "v:0", "e:208:0.5")
            print(
                f"path v:0 -> e:208:0.5: {len(path['points'])} points, length {path['distance']:.6f}"
            )

            field = client.field(mesh, "v:0", encoding="f32le-base64")
            distances = field["distances"]  # numpy float32 array, or array('f') without numpy
            far = max(range(len(distances)), key=lambda i: distances[i])
            print(
                f"field from v:0: {field['reached']} of {field['vertices']} vertices reached, "
                f"farthest v:{far} at {distances[far]:.6f} ({type(distances).__name__})"
            )

            near = client.field(mesh, ["v:0", "v:1500"], cutoff=0.2)
            reached = [i for i, x in enumerate(near["distances"]) if x is not None]
            print(
                f"field from v:0 and v:1500 within 0.2: {len(reached)} vertices, "
                f"{sum(near['nearest_source'][i] == 1 for i in reached)} nearer to v:1500"
            )

            m = client.matrix(mesh, ["v:0", "v:1"], ["v:2", "v:3", "s:7"])
            for row in m["distances"]:
                print("matrix row:", " ".join(f"{x:.6f}" for x in row))

            # Pipelining: 100 requests on the wire before the first reply is read.
            with client.pipeline() as pipe:
                pending = [pipe.distance(mesh, "v:0", f"v:{i}") for i in range(100)]
            total = math.fsum(p.result()["distance"] for p in pending)
            print(f"pipelined 100 distances from v:0, sum {total:.6f}")

            # Errors carry the server's reason.
            try:
                client.distance(mesh, "v:0", "f:99999:1:0:0")
            except geoprox.ServerError as e:
                print(f"error {e.reason} (code {e.code}, retryable {e.retryable}): {e.message}")
    except geoprox.GeoproxConnectionError as e:
        print(f"query.py: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
