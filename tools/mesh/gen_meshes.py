#!/usr/bin/env python3
"""Generate the project's own tetrahedral meshes (meshes/robot.vtu, meshes/sheet.vtu).

Structured tetrahedralisation: an implicit shape is sampled on a regular grid of cubes
(kept when the cube centre is inside), each cube is split into the 6 Kuhn tetrahedra
(conforming across neighbours), unused nodes are dropped. Units: mm.

- robot: a four-legged cable-driven parallel soft robot of the diamond robot's size and
  class: a base block (fixed), four flat legs in the x=0 and y=0 planes bending out to knees
  at radius 97 mm, height 45 mm (the cable attach points), and a top platform up to z = 125 mm.
- sheet: a 200 x 200 x 4 mm plate (its four corners are fixed in the model file).

Usage: python3 tools/mesh/gen_meshes.py [OUT_DIR] [--robot-h MM] [--only robot|sheet]
(default meshes/, h = 8.8 mm, both meshes). --robot-h sets the robot's cube size: 4.4 makes
a 2x finer conforming mesh of the same robot (OUT_DIR/robot.vtu, ~8x the tetrahedra), a
truth that is not the model for a scene's [truth] mesh:
    python3 tools/mesh/gen_meshes.py /tmp/fine --robot-h 4.4 --only robot
Deterministic: same output bytes on every run.
"""
import argparse
import itertools
import math
import sys
from pathlib import Path


def seg_dist(p, a, b):
    ax, ay = b[0] - a[0], b[1] - a[1]
    t = ((p[0] - a[0]) * ax + (p[1] - a[1]) * ay) / (ax * ax + ay * ay)
    t = max(0.0, min(1.0, t))
    dx, dy = p[0] - (a[0] + t * ax), p[1] - (a[1] + t * ay)
    return math.hypot(dx, dy)


# Leg centre line in the (radius, z) plane, mm.
LEG = [(0.0, 6.0), (97.0, 45.0), (25.0, 117.0), (0.0, 118.0)]
LEG_HALF_WIDTH = 11.0  # in the leg plane
LEG_HALF_THICK = 13.0  # across the leg plane


def robot_inside(x, y, z):
    if abs(x) <= 15 and abs(y) <= 15 and 0 <= z <= 12:
        return True  # base block (fixed)
    if abs(x) <= 28 and abs(y) <= 28 and 110 <= z <= 125:
        return True  # top platform, tip at (0, 0, 125)
    for r, t in ((x, y), (y, x), (-x, y), (-y, x)):
        if r >= 0 and abs(t) <= LEG_HALF_THICK:
            d = min(seg_dist((r, z), LEG[i], LEG[i + 1]) for i in range(len(LEG) - 1))
            if d <= LEG_HALF_WIDTH:
                return True
    return False


def kuhn_mesh(lo, n, h, inside):
    """Cubes of size h from corner lo, n cells per axis, kept if inside(centre)."""
    nodes = {}
    pts = []
    tets = []

    def node(i, j, k):
        key = (i, j, k)
        if key not in nodes:
            nodes[key] = len(pts)
            pts.append((lo[0] + i * h[0], lo[1] + j * h[1], lo[2] + k * h[2]))
        return nodes[key]

    for k in range(n[2]):
        for j in range(n[1]):
            for i in range(n[0]):
                c = (lo[0] + (i + .5) * h[0], lo[1] + (j + .5) * h[1], lo[2] + (k + .5) * h[2])
                if not inside(*c):
                    continue
                for perm in itertools.permutations(range(3)):
                    cur = [0, 0, 0]
                    path = [tuple(cur)]
                    for ax in perm:
                        cur[ax] += 1
                        path.append(tuple(cur))
                    t = [node(i + a, j + b, k + d) for (a, b, d) in path]
                    tets.append(t)
    # orient positively
    out = []
    for t in tets:
        a, b, c, d = (pts[v] for v in t)
        u = [b[q] - a[q] for q in range(3)]
        v = [c[q] - a[q] for q in range(3)]
        w = [d[q] - a[q] for q in range(3)]
        vol = (u[1] * v[2] - u[2] * v[1]) * w[0] + (u[2] * v[0] - u[0] * v[2]) * w[1] + (u[0] * v[1] - u[1] * v[0]) * w[2]
        out.append(t if vol > 0 else [t[0], t[1], t[3], t[2]])
    return pts, out


def write_vtu(path, pts, tets, comment):
    with open(path, "w") as f:
        f.write('<?xml version="1.0"?>\n<!-- %s -->\n' % comment)
        f.write('<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">\n<UnstructuredGrid>\n')
        f.write('<Piece NumberOfPoints="%d" NumberOfCells="%d">\n' % (len(pts), len(tets)))
        f.write('<Points>\n<DataArray type="Float64" NumberOfComponents="3" format="ascii">\n')
        for p in pts:
            f.write("%.6g %.6g %.6g\n" % p)
        f.write('</DataArray>\n</Points>\n<Cells>\n<DataArray type="Int32" Name="connectivity" format="ascii">\n')
        for t in tets:
            f.write("%d %d %d %d\n" % tuple(t))
        f.write('</DataArray>\n<DataArray type="Int32" Name="offsets" format="ascii">\n')
        f.write("\n".join(str(4 * (i + 1)) for i in range(len(tets))))
        f.write('\n</DataArray>\n<DataArray type="UInt8" Name="types" format="ascii">\n')
        f.write("\n".join("10" for _ in tets))
        f.write("\n</DataArray>\n</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n")


ROBOT_H = 8.8  # mm, the bundled meshes/robot.vtu


def main():
    ap = argparse.ArgumentParser(description="Generate the project's tetrahedral meshes.")
    ap.add_argument("out", nargs="?", default="meshes", help="output folder (meshes)")
    ap.add_argument("--robot-h", type=float, default=ROBOT_H, help="robot cube size, mm (8.8)")
    ap.add_argument("--only", choices=["robot", "sheet"], help="write only this mesh")
    args = ap.parse_args()
    if not (0.5 <= args.robot_h <= 50.0):
        sys.exit("--robot-h must be within 0.5-50 mm")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.only in (None, "robot"):
        h = args.robot_h
        n = int(math.ceil(220 / h))
        lo = (-n * h / 2, -n * h / 2, 0.0)
        pts, tets = kuhn_mesh(lo, (n, n, int(math.ceil(125 / h))), (h, h, 125 / math.ceil(125 / h)), robot_inside)
        comment = "softsense four-legged cable robot, mm, tools/mesh/gen_meshes.py"
        if h != ROBOT_H:
            comment += " --robot-h %g" % h
        write_vtu(out / "robot.vtu", pts, tets, comment)
        print("robot: %d nodes, %d tets" % (len(pts), len(tets)))
    if args.only == "robot":
        return
    pts, tets = kuhn_mesh((-100.0, -100.0, 0.0), (20, 20, 2), (10.0, 10.0, 2.0), lambda x, y, z: True)
    write_vtu(out / "sheet.vtu", pts, tets, "softsense soft sheet 200x200x4 mm, tools/mesh/gen_meshes.py")
    print("sheet: %d nodes, %d tets" % (len(pts), len(tets)))


if __name__ == "__main__":
    main()
