#!/usr/bin/env python3
"""Wall time of an N x N matrix of random face points through geoproxd from the Python client,
numpy in and out (geoprox.faces(...), as_array=True), over TCP and over HTTP; and, for
comparison, the same matrix as JSON lists over TCP. Prints the median of --runs runs and the
cost per pair, and checks that the transports' answers are the same bits.

    python3 bench/python_client_matrix.py --port 7878 --http-url http://127.0.0.1:7880 \\
        --mesh lucy --n 1000 --runs 3

Needs numpy (Debian: /usr/bin/python3 with python3-numpy) and clients/python on PYTHONPATH
(done here from this file's place). The daemon's limits must allow N x N pairs and 2 N points
(max_matrix_pairs, max_points_per_request, max_line_bytes, max_output_bytes, max_timeout_ms).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "clients" / "python"))

import geoprox  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=7878)
    parser.add_argument("--http-url", default="http://127.0.0.1:7880")
    parser.add_argument("--mesh", default="lucy")
    parser.add_argument("--n", type=int, default=1000, help="sources = targets = N face points")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--timeout-ms", type=int, default=600000)
    parser.add_argument("--cases", default="tcp,http,json",
                        help="which of tcp (numpy), http (numpy), json (TCP, lists) to run")
    args = parser.parse_args()
    np = geoprox.arrays.require_numpy("this benchmark")

    with geoprox.Client(args.host, args.port, timeout=None) as client:
        client.wait_ready(args.mesh, timeout=3600)
        info = client.mesh_info(args.mesh)
        limits = client.server_info()["limits"]
    faces = int(info["faces"])
    print(f"mesh {args.mesh}: {info['vertices']} vertices, {faces} faces; limits "
          + ", ".join(f"{k} {limits[k]}" for k in ("max_matrix_pairs", "max_points_per_request",
                                                   "max_line_bytes", "max_output_bytes",
                                                   "max_timeout_ms")))
    rng = np.random.default_rng(args.seed)
    bary = rng.random((2 * args.n, 3)) + 1e-3
    bary /= bary.sum(axis=1, keepdims=True)
    points = geoprox.faces(rng.integers(0, faces, size=2 * args.n), bary)
    sources, targets = points[: args.n], points[args.n :]
    pairs = args.n * args.n

    answers = {}
    cases = {"tcp": ("tcp, numpy in and out", args.host, True),
             "http": ("http, numpy in and out", args.http_url, True),
             "json": ("tcp, JSON lists out", args.host, False)}
    for name, where, as_array in (cases[c] for c in args.cases.split(",")):
        with geoprox.Client(where, args.port, timeout=None) as client:
            times = []
            for _ in range(args.runs):
                start = time.perf_counter()
                result = client.matrix(args.mesh, sources, targets, as_array=as_array,
                                       timeout_ms=args.timeout_ms)
                times.append(time.perf_counter() - start)
        distances = np.array(result["distances"], dtype=float) if not as_array \
            else result["distances"]
        answers[name] = distances
        median = statistics.median(times)
        print(f"{name}: median {median:.3f} s of {args.runs} "
              f"({', '.join(f'{t:.3f}' for t in times)}), {median / pairs * 1e6:.3f} us per pair, "
              f"unreachable {result['unreachable']}")
    names = list(answers)
    first = np.asarray(answers[names[0]], dtype=np.float64).view(np.uint64)
    for name in names[1:]:
        same = np.array_equal(first, np.asarray(answers[name], dtype=np.float64).view(np.uint64))
        print(f"{name}: same bits as {names[0]}: {same}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
