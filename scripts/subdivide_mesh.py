#!/usr/bin/env python3
# Flat k-by-k subdivision of a triangle mesh (OBJ or OFF in, OBJ out), for the study of
# whether proximity-graph samples inside faces (paper Fig. 3) beat vertex-only samples:
# the output is the same polyhedral surface with extra vertices on edges and inside faces.
"""Usage: subdivide_mesh.py IN.(obj|off) OUT.obj [--k K] [--shuffle SEED]

Each triangle is split into k*k similar triangles. Points on an edge are shared by the
faces of that edge (keyed by the sorted vertex pair), so the topology is unchanged.
Original vertices come first in their original order (`geoprox build --candidate-vertices V`
then keeps samples at them); face orientation is kept. --shuffle SEED permutes the original
vertices among themselves and the new ones among themselves (faces follow): farthest-point
sampling starts at vertex 0, so shuffled copies give other valid sample sets, the noise
against which a difference in accuracy is judged (docs/accuracy.md). --k 1 only shuffles.
"""
import random
import argparse
import sys


def read_obj(path):
    verts, faces = [], []
    with open(path) as f:
        for line in f:
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "v":
                verts.append((float(parts[1]), float(parts[2]), float(parts[3])))
            elif parts[0] == "f":
                idx = []
                for p in parts[1:]:
                    i = int(p.split("/")[0])
                    idx.append(i - 1 if i > 0 else len(verts) + i)
                if len(idx) != 3:
                    sys.exit("error: non-triangle face in %s" % path)
                faces.append(tuple(idx))
    return verts, faces


def read_off(path):
    with open(path) as f:
        tokens = []
        for line in f:
            line = line.split("#", 1)[0]
            tokens.extend(line.split())
    pos = 0
    head = tokens[pos]
    if head.upper() == "OFF":
        pos += 1
    elif head.upper().startswith("OFF"):  # e.g. "OFF10 5 0" written without space
        tokens[pos] = head[3:]
    nv, nf = int(tokens[pos]), int(tokens[pos + 1])
    pos += 3
    verts = []
    for _ in range(nv):
        verts.append(tuple(float(t) for t in tokens[pos:pos + 3]))
        pos += 3
    faces = []
    for _ in range(nf):
        n = int(tokens[pos])
        if n != 3:
            sys.exit("error: non-triangle face in %s" % path)
        faces.append(tuple(int(t) for t in tokens[pos + 1:pos + 4]))
        pos += 1 + n
    return verts, faces


def lerp(a, b, t):
    return tuple(a[i] + (b[i] - a[i]) * t for i in range(3))


def subdivide(verts, faces, k):
    out_v = list(verts)
    edge_pts = {}  # (lo, hi) -> list of k-1 vertex ids going from lo to hi

    def edge_point(a, b, j):
        """Id of the point at fraction j/k from a to b (0 < j < k)."""
        key = (a, b) if a < b else (b, a)
        pts = edge_pts.get(key)
        if pts is None:
            lo, hi = key
            pts = []
            for s in range(1, k):
                pts.append(len(out_v))
                out_v.append(lerp(verts[lo], verts[hi], s / k))
            edge_pts[key] = pts
        return pts[j - 1] if a < b else pts[k - j - 1]

    out_f = []
    for (a, b, c) in faces:
        pa, pb, pc = verts[a], verts[b], verts[c]
        # grid[i][j]: point a + (i/k)(b-a) + (j/k)(c-a), i + j <= k
        grid = {}
        for i in range(k + 1):
            for j in range(k + 1 - i):
                l = k - i - j  # weight of a
                if i == 0 and j == 0:
                    vid = a
                elif i == k:
                    vid = b
                elif j == k:
                    vid = c
                elif j == 0:
                    vid = edge_point(a, b, i)
                elif i == 0:
                    vid = edge_point(a, c, j)
                elif l == 0:
                    vid = edge_point(b, c, j)
                else:
                    vid = len(out_v)
                    out_v.append(tuple((l * pa[t] + i * pb[t] + j * pc[t]) / k
                                       for t in range(3)))
                grid[(i, j)] = vid
        for i in range(k):
            for j in range(k - i):
                # upward triangle, same orientation as (a, b, c)
                out_f.append((grid[(i, j)], grid[(i + 1, j)], grid[(i, j + 1)]))
                if i + j < k - 1:
                    out_f.append((grid[(i + 1, j)], grid[(i + 1, j + 1)], grid[(i, j + 1)]))
    return out_v, out_f, len(edge_pts)


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("input")
    ap.add_argument("output")
    ap.add_argument("--k", type=int, default=2, help="splits per edge (default 2)")
    ap.add_argument("--shuffle", type=int, default=None, metavar="SEED",
                    help="permute vertex ids (originals among themselves, new ones too)")
    args = ap.parse_args()
    if args.k < 1:
        sys.exit("error: --k must be >= 1")
    if args.input.lower().endswith(".off"):
        verts, faces = read_off(args.input)
    else:
        verts, faces = read_obj(args.input)
    k = args.k
    out_v, out_f, n_edges = subdivide(verts, faces, k)
    V, F, E = len(verts), len(faces), n_edges
    want_v = V + E * (k - 1) + F * (k - 1) * (k - 2) // 2
    want_f = F * k * k
    if args.shuffle is not None:
        rng = random.Random(args.shuffle)
        old, new = list(range(V)), list(range(V, len(out_v)))
        rng.shuffle(old)
        rng.shuffle(new)
        order = old + new            # order[i]: the vertex that gets id i
        new_id = [0] * len(out_v)
        for i, v in enumerate(order):
            new_id[v] = i
        out_v = [out_v[v] for v in order]
        out_f = [tuple(new_id[v] for v in t) for t in out_f]
    with open(args.output, "w") as f:
        f.write("# flat %dx%d subdivision of %s\n" % (k, k, args.input))
        for v in out_v:
            f.write("v %.17g %.17g %.17g\n" % v)
        for t in out_f:
            f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))
    print("input:  V=%d E=%d F=%d" % (V, E, F))
    print("output: V=%d F=%d (k=%d)" % (len(out_v), len(out_f), k))
    ok = len(out_v) == want_v and len(out_f) == want_f
    print("count check: V + E(k-1) + F(k-1)(k-2)/2 = %d, F k^2 = %d: %s"
          % (want_v, want_f, "ok" if ok else "MISMATCH"))
    if not ok:
        sys.exit(1)


if __name__ == "__main__":
    main()
