"""Tetrahedra inside closed STL shells, by gmsh (softsense model new runs this file).

Usage: python gmsh_tets.py JOB.json. JOB: {"shells": [outer.stl, cavity.stl, ...],
"size": edge length, "keep_surface": bool, "out": mesh.msh, "result": result.json}.
Exit 3 when gmsh cannot be imported, 4 when meshing fails; the reason is on stderr.
"""
import json
import math
import sys
import time


def shells_of_surfaces(gmsh, surfaces):
    # Surfaces that share a boundary curve belong to one shell.
    parent = {s: s for s in surfaces}

    def find(s):
        while parent[s] != s:
            parent[s] = parent[parent[s]]
            s = parent[s]
        return s

    owner = {}
    for s in surfaces:
        for _, c in gmsh.model.getBoundary([(2, s)], oriented=False):
            c = abs(c)
            if c in owner:
                parent[find(s)] = find(owner[c])
            else:
                owner[c] = s
    groups = {}
    for s in surfaces:
        groups.setdefault(find(s), []).append(s)
    return list(groups.values())


def bbox_volume(gmsh, group):
    lo, hi = [math.inf] * 3, [-math.inf] * 3
    for s in group:
        b = gmsh.model.getBoundingBox(2, s)
        lo = [min(lo[k], b[k]) for k in range(3)]
        hi = [max(hi[k], b[k + 3]) for k in range(3)]
    return (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2])


def volume_from(gmsh, groups):
    groups = sorted(groups, key=lambda g: -bbox_volume(gmsh, g))
    loops = [gmsh.model.geo.addSurfaceLoop(g) for g in groups]
    gmsh.model.geo.addVolume(loops)
    gmsh.model.geo.synchronize()


def build(gmsh, job, remesh):
    gmsh.clear()
    for path in job["shells"]:
        gmsh.merge(path)
    if remesh:
        # Faces split where they meet at more than 40 degrees, then remeshed to the size.
        gmsh.model.mesh.classifySurfaces(40 * math.pi / 180, True, True, math.pi)
        gmsh.model.mesh.createGeometry()
        gmsh.model.geo.synchronize()
        surfaces = [t for _, t in gmsh.model.getEntities(2)]
        volume_from(gmsh, shells_of_surfaces(gmsh, surfaces))
    else:
        # One merged file is one discrete surface: the triangles are kept as given.
        volume_from(gmsh, [[t] for _, t in gmsh.model.getEntities(2)])
    gmsh.option.setNumber("Mesh.MeshSizeMax", job["size"])
    gmsh.option.setNumber("Mesh.MeshSizeMin", job["size"] / 4)
    gmsh.model.mesh.generate(3)
    gmsh.model.mesh.optimize("Netgen")


def main():
    job = json.load(open(sys.argv[1]))
    try:
        import gmsh
    except ImportError as e:
        print(f"gmsh is not importable by {sys.executable} ({e})", file=sys.stderr)
        sys.exit(3)
    t0 = time.time()
    gmsh.initialize(["gmsh", "-nt", "1"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    remeshed = not job["keep_surface"]
    try:
        try:
            build(gmsh, job, remeshed)
        except Exception:
            if not remeshed:
                raise
            # CAD faces that cannot be parametrised: mesh inside the triangles as given.
            remeshed = False
            build(gmsh, job, False)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.option.setNumber("Mesh.Binary", 0)
        gmsh.write(job["out"])
    except Exception as e:
        print(f"gmsh could not mesh the surface: {e}", file=sys.stderr)
        sys.exit(4)
    finally:
        gmsh.finalize()
    result = {"gmsh": gmsh.__version__, "surface_remeshed": remeshed, "seconds": time.time() - t0}
    json.dump(result, open(job["result"], "w"))


if __name__ == "__main__":
    main()
