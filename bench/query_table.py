#!/usr/bin/env python3
"""Query benchmark table (issue 4, section 8). Not a test: it only measures.

For each mesh given by path: builds its graph with the default (Table 1) parameters unless a
graph file is already there, then runs `geoprox eval --json` (random pairs uniform by area,
exact references from the full exact solver, fast marching on the same pairs) and prints one
row per mesh:

    mesh, faces, samples, p2p p50/p99, path p50, field, mean/p99/max error, fmm mean/max error

Usage:
    bench/query_table.py --geoprox build/clients/cli/geoprox [--pairs 10000] [--fields 3]
                         [--graph-dir /tmp/geoprox-bench] MESH...

Standard library only. Timings are medians of the single-threaded queries of one run; run it
several times (or compare against a baseline in the same session) on a noisy machine.
"""
import argparse
import json
import os
import subprocess
import sys


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("meshes", nargs="+", metavar="MESH")
    parser.add_argument("--geoprox", required=True, help="path of the geoprox binary")
    parser.add_argument("--pairs", type=int, default=10000)
    parser.add_argument("--fields", type=int, default=3)
    parser.add_argument("--paths", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--graph-dir", default="/tmp/geoprox-bench")
    args = parser.parse_args()

    os.makedirs(args.graph_dir, exist_ok=True)
    rows = []
    for mesh in args.meshes:
        name = os.path.splitext(os.path.basename(mesh))[0]
        graph = os.path.join(args.graph_dir, name + ".geoprox")
        if not os.path.exists(graph):
            subprocess.run([args.geoprox, "build", mesh, "-o", graph, "--quiet"], check=True)
        out = subprocess.run(
            [args.geoprox, "eval", mesh, graph, "--pairs", str(args.pairs), "--fields",
             str(args.fields), "--paths", str(args.paths), "--seed", str(args.seed), "--json"],
            check=True, capture_output=True, text=True).stdout
        sys.stderr.write(out)
        figures = json.loads(out.strip().splitlines()[-1])
        figures["name"] = name
        rows.append(figures)

    header = ("| mesh | faces | samples | p2p p50 | p2p p99 | path p50 | field | mean err | "
              "p99 err | max err | fmm mean | fmm max |")
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    for r in rows:
        print(f"| {r['name']} | {r['faces']} | {r['samples']} | {r['p2p_ms']['p50']:.3f} ms | "
              f"{r['p2p_ms']['p99']:.3f} ms | {r['path_ms']['p50']:.3f} ms | "
              f"{r['field_ms']:.2f} ms | {100 * r['error']['mean']:.3f}% | "
              f"{100 * r['error']['p99']:.3f}% | {100 * r['error']['max']:.3f}% | "
              f"{100 * r['fmm_error']['mean']:.3f}% | {100 * r['fmm_error']['max']:.2f}% |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
