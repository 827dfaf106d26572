#!/usr/bin/env python3
# CAD-like test meshes (issue 43): tessellations as CAD exporters write them, with faces much
# longer than the spacing of a proximity graph's samples, thin parts and many small components.
"""Usage: make_cad_meshes.py OUT_DIR [--polygons] [--only NAME...]

Writes OBJ files to OUT_DIR (created if missing), each outward-oriented and closed:

  cylinder.obj      capped cylinder, radius 1, height 10, 64 segments, one ring of long side
                    faces (each side quad split in two); caps as a fan around a centre vertex
                    (130 vertices, 256 faces)
  l-prism.obj       L-shaped prism (4 x 4 outline, arms 1 thick, height 10): non-convex caps
                    ear-clipped without extra vertices, long side quads split in two
  star-prism.obj    8-pointed star prism (radii 2 and 0.8, height 10): non-convex caps
                    ear-clipped, long side quads split in two
  long-box.obj      box 10 x 1 x 1, two triangles per face
  slab.obj          thin slab 10 x 10 x 0.05, two triangles per face
  boxes.obj         40 small boxes (sides 0.2 to 1) on a 10 x 10 grid, two triangles per face:
                    40 components
  cylinders.obj     40 small capped cylinders (radius 0.1 to 0.5, 16 segments) on a grid

With --polygons, also the same surfaces as CAD polygons (files *-poly.obj): quads for the
sides and boxes, each cap one polygon (a 64-gon for the cylinder, the non-convex outline for
the prisms). Their vertices are those of the triangle versions less the cap centres.

Standard library only; the output depends on nothing but the arguments.
"""
import argparse
import math
import os
import sys


class Mesh:
    """Vertices and polygons (0-based vertex ids, counter-clockwise seen from outside)."""

    def __init__(self):
        self.verts = []
        self.faces = []

    def vertex(self, x, y, z):
        self.verts.append((x, y, z))
        return len(self.verts) - 1

    def add(self, other):
        base = len(self.verts)
        self.verts.extend(other.verts)
        self.faces.extend(tuple(base + v for v in f) for f in other.faces)

    def triangulated(self):
        """Triangles only: quads split along one diagonal, other polygons ear-clipped."""
        out = Mesh()
        out.verts = list(self.verts)
        for f in self.faces:
            if len(f) == 3:
                out.faces.append(f)
            elif len(f) == 4:
                out.faces.append((f[0], f[1], f[2]))
                out.faces.append((f[0], f[2], f[3]))
            else:
                out.faces.extend(ear_clip(self.verts, f))
        return out

    def write(self, path, comment):
        with open(path, "w") as out:
            out.write("# %s\n" % comment)
            for v in self.verts:
                out.write("v %.17g %.17g %.17g\n" % v)
            for f in self.faces:
                out.write("f %s\n" % " ".join(str(v + 1) for v in f))


def polygon_normal(verts, face):
    """Newell's normal of a planar polygon (not normalised)."""
    n = [0.0, 0.0, 0.0]
    for k in range(len(face)):
        a, b = verts[face[k]], verts[face[(k + 1) % len(face)]]
        n[0] += (a[1] - b[1]) * (a[2] + b[2])
        n[1] += (a[2] - b[2]) * (a[0] + b[0])
        n[2] += (a[0] - b[0]) * (a[1] + b[1])
    return n


def ear_clip(verts, face):
    """Triangles of a simple planar polygon (any convexity), in its orientation."""
    n = polygon_normal(verts, face)
    axis = max(range(3), key=lambda k: abs(n[k]))
    u, v = [(1, 2), (2, 0), (0, 1)][axis]
    sign = 1.0 if n[axis] > 0 else -1.0
    pts = {i: (verts[i][u], verts[i][v]) for i in face}

    def cross(o, a, b):
        return sign * ((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))

    def inside(p, a, b, c):
        return cross(a, b, p) >= 0 and cross(b, c, p) >= 0 and cross(c, a, p) >= 0

    ring = list(face)
    triangles = []
    while len(ring) > 3:
        for k in range(len(ring)):
            a, b, c = ring[k - 1], ring[k], ring[(k + 1) % len(ring)]
            if cross(pts[a], pts[b], pts[c]) <= 0:
                continue  # reflex (or flat) corner: not an ear
            if any(inside(pts[x], pts[a], pts[b], pts[c]) for x in ring if x not in (a, b, c)):
                continue
            triangles.append((a, b, c))
            del ring[k]
            break
        else:
            sys.exit("error: ear clipping found no ear (polygon not simple?)")
    triangles.append(tuple(ring))
    return triangles


def prism(outline, height, x0=0.0, y0=0.0, z0=0.0, cap_fan=False):
    """An outline (counter-clockwise in xy) extruded along z: side quads, caps as one polygon
    each, or with cap_fan as a fan around a centre vertex (the outline's mean)."""
    m = Mesh()
    n = len(outline)
    bottom = [m.vertex(x0 + x, y0 + y, z0) for x, y in outline]
    top = [m.vertex(x0 + x, y0 + y, z0 + height) for x, y in outline]
    for k in range(n):
        j = (k + 1) % n
        m.faces.append((bottom[k], bottom[j], top[j], top[k]))
    if cap_fan:
        cx = sum(p[0] for p in outline) / n
        cy = sum(p[1] for p in outline) / n
        cb = m.vertex(x0 + cx, y0 + cy, z0)
        ct = m.vertex(x0 + cx, y0 + cy, z0 + height)
        for k in range(n):
            j = (k + 1) % n
            m.faces.append((cb, bottom[j], bottom[k]))
            m.faces.append((ct, top[k], top[j]))
    else:
        m.faces.append(tuple(reversed(bottom)))
        m.faces.append(tuple(top))
    return m


def circle(radius, segments):
    return [(radius * math.cos(2 * math.pi * k / segments),
             radius * math.sin(2 * math.pi * k / segments)) for k in range(segments)]


def box(sx, sy, sz, x0=0.0, y0=0.0, z0=0.0):
    return prism([(0, 0), (sx, 0), (sx, sy), (0, sy)], sz, x0, y0, z0)


def l_outline():
    return [(0, 0), (4, 0), (4, 1), (1, 1), (1, 4), (0, 4)]


def star_outline(points=8, outer=2.0, inner=0.8):
    out = []
    for k in range(2 * points):
        r = outer if k % 2 == 0 else inner
        a = math.pi * k / points
        out.append((r * math.cos(a), r * math.sin(a)))
    return out


def grid_positions(count, columns, spacing):
    return [((k % columns) * spacing, (k // columns) * spacing) for k in range(count)]


def many_boxes():
    m = Mesh()
    for k, (x, y) in enumerate(grid_positions(40, 8, 1.25)):
        s = 0.2 + 0.8 * ((k * 7) % 40) / 39  # sides 0.2 to 1, mixed over the grid
        m.add(box(s, s * (0.5 + 0.5 * (k % 3) / 2), s * (0.3 + 0.7 * (k % 5) / 4), x, y))
    return m


def many_cylinders(cap_fan):
    m = Mesh()
    for k, (x, y) in enumerate(grid_positions(40, 8, 1.25)):
        r = 0.1 + 0.4 * ((k * 11) % 40) / 39
        m.add(prism(circle(r, 16), 0.2 + 0.8 * (k % 4) / 3, x, y, cap_fan=cap_fan))
    return m


# name: (polygon mesh, mesh to triangulate when not the polygon one, description)
def all_meshes():
    return {
        "cylinder": (prism(circle(1, 64), 10), prism(circle(1, 64), 10, cap_fan=True),
                     "capped cylinder r 1, h 10, 64 segments, one ring of long side faces"),
        "l-prism": (prism(l_outline(), 10), None, "L-shaped prism 4 x 4 x 10, arms 1 thick"),
        "star-prism": (prism(star_outline(), 10), None, "8-pointed star prism, radii 2 / 0.8, h 10"),
        "long-box": (box(10, 1, 1), None, "box 10 x 1 x 1"),
        "slab": (box(10, 10, 0.05), None, "thin slab 10 x 10 x 0.05"),
        "boxes": (many_boxes(), None, "40 small boxes, sides 0.2 to 1"),
        "cylinders": (many_cylinders(False), many_cylinders(True),
                      "40 small capped cylinders, r 0.1 to 0.5, 16 segments"),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out_dir")
    ap.add_argument("--polygons", action="store_true",
                    help="also write the polygon versions (*-poly.obj)")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="write only these meshes")
    args = ap.parse_args()
    meshes = all_meshes()
    names = args.only or list(meshes)
    for name in names:
        if name not in meshes:
            sys.exit("error: unknown mesh %r (known: %s)" % (name, ", ".join(meshes)))
    os.makedirs(args.out_dir, exist_ok=True)
    for name in names:
        poly, tri, what = meshes[name]
        tri = (tri if tri is not None else poly).triangulated()
        path = os.path.join(args.out_dir, name + ".obj")
        tri.write(path, what + " (triangles)")
        print("%-22s %5d vertices %5d faces" % (path, len(tri.verts), len(tri.faces)))
        if args.polygons:
            path = os.path.join(args.out_dir, name + "-poly.obj")
            poly.write(path, what + " (polygons)")
            print("%-22s %5d vertices %5d faces" % (path, len(poly.verts), len(poly.faces)))


if __name__ == "__main__":
    main()
