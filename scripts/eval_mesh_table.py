#!/usr/bin/env python3
# Accuracy table over a list of meshes (issue 43): build each one's graph with geoprox build
# (timed), run geoprox eval --json against the exact solver, print one markdown row per mesh.
"""Usage: eval_mesh_table.py --geoprox BIN [options] MESH...

For each MESH: optional preparation steps (--prepare repair, --prepare refine: `geoprox STEP
MESH -o COPY.obj`, in the order given, each on the previous step's output), then `geoprox build`
with any --build-args, then `geoprox eval --json` on the prepared mesh. One markdown row per
mesh:

  mesh | faces | class | loads | warns | p2p mean | p2p worst | field worst | below exact | build

faces are the input file's (geoprox info, else counted in the file), loads is y when every step and the build succeeded
(else n and the first words of the failing step's error), warns is y when the build printed a
warning (geoprox: warning: ...), below exact counts pair and field answers below the exact
distance, and build is the wall time of the preparation steps plus the build, in seconds.

Classes come from --class NAME=CLASS (NAME the file name without directory), else from the
table of known corpus meshes below, else "-".

Standard library only. Build times are of one run on a possibly shared machine.
"""
import argparse
import json
import os
import re
import shlex
import subprocess
import sys
import time

# Classes of the optional corpus's meshes ($GEOPROX_SHARED_MESHES) and of
# scripts/make_cad_meshes.py's.
KNOWN_CLASSES = {
    "cylinder.obj": "CAD, long faces",
    "l-prism.obj": "CAD, long faces",
    "star-prism.obj": "CAD, long faces",
    "long-box.obj": "CAD, long faces",
    "slab.obj": "CAD, thin, long faces",
    "boxes.obj": "CAD, many components",
    "cylinders.obj": "CAD, many components",
    "truck.obj": "dirty CAD car",
    "teapot.obj": "dirty, open",
    "happy-buddha-dirty.ply": "dirty scan",
    "pig.stl": "STL, animal",
    "spot.obj": "animal",
    "bunny.off": "scan",
    "blade.off": "poor triangles",
    "plane_holes.obj": "open, holes",
    "fertility.off": "scan, genus 4",
    "camelhead.off": "open scan",
    "vase-lion.off": "scan",
    "cheese.off": "poor triangles, genus 133",
    "moai.obj": "scan",
    "decimated-max.obj": "scan",
    "ChineseDragon-10kv.off": "scan, open",
}


def first_words(text, count=8):
    """The first `count` words of a tool's error, without its "geoprox: error:" prefix."""
    lines = [l for l in text.strip().splitlines() if l.strip()]
    if not lines:
        return "no output"
    line = next((l for l in lines if "error" in l.lower()), lines[-1])
    line = re.sub(r"^geoprox:\s*(error:\s*)?", "", line.strip())
    words = line.split()
    return " ".join(words[:count]) + (" ..." if len(words) > count else "")


def run(cmd, timeout):
    """(returncode, stdout, stderr, seconds); returncode None on timeout."""
    start = time.monotonic()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        return p.returncode, p.stdout, p.stderr, time.monotonic() - start
    except subprocess.TimeoutExpired:
        return None, "", "timed out after %d s" % timeout, time.monotonic() - start


def count_faces(mesh):
    """Faces of a mesh file by its header or records, for files geoprox does not load."""
    ext = os.path.splitext(mesh)[1].lower()
    try:
        with open(mesh, "rb") as f:
            data = f.read()
    except OSError:
        return None
    if ext == ".obj":
        return sum(1 for line in data.splitlines() if line.startswith(b"f "))
    if ext == ".off":
        tokens = re.sub(rb"#[^\n]*", b"", data).split()
        start = 1 if tokens and tokens[0].upper().startswith(b"OFF") else 0
        return int(tokens[start + 1])
    if ext == ".ply":
        m = re.search(rb"element face (\d+)", data[:4096])
        return int(m.group(1)) if m else None
    if ext == ".stl":
        if data[:5].lower() == b"solid" and b"facet" in data[:1024]:
            return data.count(b"facet normal")
        return int.from_bytes(data[80:84], "little") if len(data) >= 84 else None
    return None


def input_faces(geoprox, mesh, timeout):
    rc, out, _, _ = run([geoprox, "info", mesh], timeout)
    if rc == 0:
        m = re.search(r"^\s*faces:\s*([\d,]+)", out, re.MULTILINE)
        if m:
            return int(m.group(1).replace(",", ""))
    return count_faces(mesh)


def measure(args, mesh, index):
    name = os.path.basename(mesh)
    stem = "%02d-%s" % (index, os.path.splitext(name)[0])
    row = {"mesh": name, "class": args.classes.get(name, KNOWN_CLASSES.get(name, "-")),
           "faces": input_faces(args.geoprox, mesh, args.timeout), "loads": "y", "warns": "",
           "build_s": 0.0, "eval": None, "warning": ""}
    served = mesh
    for step in args.prepare:
        out = os.path.join(args.work_dir, "%s-%s.obj" % (stem, step))
        rc, _, err, seconds = run([args.geoprox, step, served, "-o", out], args.timeout)
        row["build_s"] += seconds
        if rc != 0:
            row["loads"] = "n (%s: %s)" % (step, first_words(err))
            return row
        served = out
    graph = os.path.join(args.work_dir, stem + ".graph")
    cmd = [args.geoprox, "build", served, "-o", graph, "--quiet"] + args.build_args
    rc, _, err, seconds = run(cmd, args.timeout)
    row["build_s"] += seconds
    warnings = [l for l in err.splitlines() if "warning" in l.lower()]
    row["warns"] = "y" if warnings else "n"
    row["warning"] = warnings[0] if warnings else ""
    if rc != 0:
        row["loads"] = "n (%s)" % first_words(err)
        return row
    cmd = [args.geoprox, "eval", served, graph, "--json", "--pairs", str(args.pairs),
           "--fields", str(args.fields), "--seed", str(args.seed), "--no-fmm"] + args.eval_args
    rc, out, err, _ = run(cmd, args.timeout)
    if rc != 0:
        row["loads"] = "y (eval failed: %s)" % first_words(err)
        return row
    row["eval"] = json.loads(out.strip().splitlines()[-1])
    row["eval_text"] = out
    return row


def percent(x):
    return "%.3g%%" % (100 * x) if x is not None else "-"


def table(rows):
    head = ["mesh", "faces", "class", "loads", "warns", "p2p mean", "p2p worst", "field worst",
            "below exact", "build (s)"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        e = r["eval"]
        cells = [r["mesh"], "{:,}".format(r["faces"]) if r["faces"] else "?", r["class"],
                 r["loads"], r["warns"] or "-"]
        if e:
            cells += [percent(e["error"]["mean"]), percent(e["error"]["max"]),
                      percent(e["field_error"]["max"]),
                      str(e["error"]["below_exact"] + e["field_error"]["below_exact"])]
        else:
            cells += ["-"] * 4
        cells.append("%.2f" % r["build_s"])
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("meshes", nargs="+", metavar="MESH")
    ap.add_argument("--geoprox", default="build/clients/cli/geoprox", help="geoprox binary")
    ap.add_argument("--prepare", action="append", default=[], choices=["repair", "refine"],
                    help="run `geoprox STEP` on the mesh first (repeatable, in order)")
    ap.add_argument("--build-args", default="",
                    help="extra flags for geoprox build, one shell-quoted string "
                         "(e.g. --build-args='--repair --samples 2000')")
    ap.add_argument("--eval-args", default="", help="extra flags for geoprox eval")
    ap.add_argument("--class", dest="class_of", action="append", default=[],
                    metavar="NAME=CLASS", help="class of a mesh file (repeatable)")
    ap.add_argument("--pairs", type=int, default=1000)
    ap.add_argument("--fields", type=int, default=2)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--timeout", type=int, default=1800, help="per step, seconds")
    ap.add_argument("--work-dir", default="/tmp/geoprox-mesh-table")
    ap.add_argument("--json-out", help="also write every row, eval JSON included, here")
    ap.add_argument("--warnings", action="store_true", help="list the build warnings after")
    args = ap.parse_args()
    args.build_args = shlex.split(args.build_args)
    args.eval_args = shlex.split(args.eval_args)
    args.classes = {}
    for item in args.class_of:
        name, sep, cls = item.partition("=")
        if not sep:
            sys.exit("error: --class wants NAME=CLASS, not %r" % item)
        args.classes[name] = cls
    os.makedirs(args.work_dir, exist_ok=True)
    rows = []
    for k, mesh in enumerate(args.meshes):
        print("... %s" % mesh, file=sys.stderr, flush=True)
        rows.append(measure(args, mesh, k))
    print(table(rows))
    if args.warnings:
        print()
        for r in rows:
            if r["warning"]:
                print("- %s: %s" % (r["mesh"], r["warning"].replace("geoprox: warning: ", "")))
    if args.json_out:
        with open(args.json_out, "w") as f:
            json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
