#!/usr/bin/env python3
"""Accuracy against graph size (issue 3, section 3: the paper's "empirical relationship between
the number of samples and expected accuracy", §4.4). Not a test: it only measures.

For each mesh and each (n_P, m_P) of a grid, builds a graph (m_st = 2 m_P) and runs
`geoprox eval --json` on random pairs; writes one CSV row per run and prints a markdown table.
The n_P axis is given as a multiple of the Table 1 value for the mesh's face count.

Usage:
    bench/accuracy_sweep.py --geoprox build/clients/cli/geoprox --csv docs/accuracy.csv \
        [--neighbors 6,10,14,18,24] [--sample-factors 0.5,1,2] [--pairs 2000] MESH...

Standard library only. Accuracy does not depend on machine load; the timings in the CSV do.
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile

TABLE1 = [(10000, 1300, 22), (20000, 1500, 21), (50000, 2300, 18), (100000, 5000, 18),
          (200000, 10000, 18), (300000, 15000, 18)]


def table1_samples(faces: int) -> int:
    """n_P of the paper's Table 1, interpolated like core/graph/proximity_graph.cpp."""
    if faces <= TABLE1[0][0]:
        return TABLE1[0][1]
    for (f0, n0, _), (f1, n1, _) in zip(TABLE1, TABLE1[1:]):
        if faces <= f1:
            return round(n0 + (faces - f0) / (f1 - f0) * (n1 - n0))
    return TABLE1[-1][1]


def count_faces(geoprox: str, mesh: str) -> int:
    out = subprocess.run([geoprox, "info", mesh], check=True, capture_output=True,
                         text=True).stdout
    for line in out.splitlines():
        key, _, value = line.partition(":")
        if key.strip() == "faces":
            return int(value.split()[0])
    raise RuntimeError("no face count in 'geoprox info " + mesh + "'")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("meshes", nargs="+", metavar="MESH")
    parser.add_argument("--geoprox", required=True)
    parser.add_argument("--csv", required=True, help="output CSV (replaced)")
    parser.add_argument("--neighbors", default="6,10,14,18,24")
    parser.add_argument("--sample-factors", default="0.5,1,2")
    parser.add_argument("--pairs", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()

    neighbors = [int(x) for x in args.neighbors.split(",")]
    factors = [float(x) for x in args.sample_factors.split(",")]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for mesh in args.meshes:
            faces = count_faces(args.geoprox, mesh)
            name = os.path.splitext(os.path.basename(mesh))[0]
            for factor in factors:
                samples = max(50, round(factor * table1_samples(faces)))
                for m in neighbors:
                    graph = os.path.join(tmp, f"{name}-{samples}-{m}.geoprox")
                    build = subprocess.run(
                        [args.geoprox, "build", mesh, "-o", graph, "--samples", str(samples),
                         "--neighbors", str(m)], check=True, capture_output=True, text=True)
                    seconds = next((float(l.split()[2]) for l in build.stdout.splitlines()
                                    if l.startswith("time total")), float("nan"))
                    out = subprocess.run(
                        [args.geoprox, "eval", mesh, graph, "--pairs", str(args.pairs),
                         "--fields", "1", "--paths", "0", "--no-fmm", "--seed",
                         str(args.seed), "--json"],
                        check=True, capture_output=True, text=True).stdout
                    e = json.loads(out.strip().splitlines()[-1])
                    row = {"mesh": name, "faces": faces, "samples": samples, "neighbors": m,
                           "samples_per_kface": round(1000 * samples / faces, 2),
                           "mean": e["error"]["mean"], "p99": e["error"]["p99"],
                           "max": e["error"]["max"], "field_mean": e["field_error"]["mean"],
                           "build_s": seconds, "p2p_ms": e["p2p_ms"]["p50"],
                           "size_bytes": os.path.getsize(graph)}
                    rows.append(row)
                    print(f"{name} n_P={samples} m_P={m}: mean {100 * row['mean']:.3f}% "
                          f"p99 {100 * row['p99']:.3f}% max {100 * row['max']:.3f}%",
                          file=sys.stderr, flush=True)
                    os.remove(graph)
    with open(args.csv, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)
    print("| mesh | faces | n_P | m_P | mean | p99 | max | build |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['mesh']} | {r['faces']} | {r['samples']} | {r['neighbors']} | "
              f"{100 * r['mean']:.3f}% | {100 * r['p99']:.3f}% | {100 * r['max']:.3f}% | "
              f"{r['build_s']:.2f} s |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
