"""Netgen's STL front end in a process of its own (geometry/netgen_mesher.py `mesh_surface`).

Netgen can fail on a valid closed surface at one target size and not at a nearby one, and some of
its failures are not exceptions but a C++ abort that ends the whole process (a 96-triangle cone from
`trimesh.creation.cone`: no tets at 12 mm, an abort at 5 mm, tets at 10, 8 and 4.5 mm; which size
fails even turns on the last bit of the STL's facet normals). Run here, an abort ends this process
only: the caller reads its exit status and says what happened, or tries another size.

    python geometry/netgen_worker.py SURFACE.stl OUT.npz MAXH GRADING [OPTSTEPS3D]

writes OUT.npz with `verts` (V, 3) m and `tets` (T, 4), Netgen's element nodes counted from 0, and
exits 0 (OPTSTEPS3D: Netgen's volume optimisation passes, its own default where not given); on a
Netgen exception it prints the message on its last line of stderr and exits 1. It imports nothing of
the project, so it starts in about 0.35 s (numpy and Netgen).
"""

import sys


def main(argv: list[str]) -> int:
    surface, out, maxh, grading = argv[0], argv[1], float(argv[2]), float(argv[3])
    options = {"optsteps3d": int(argv[4])} if len(argv) > 4 else {}
    import netgen.meshing as meshing
    import numpy as np
    from netgen.stl import STLGeometry

    meshing.SetMessageImportance(0)
    try:
        ng_mesh = STLGeometry(surface).GenerateMesh(maxh=maxh, grading=grading, **options)
    except Exception as exc:  # Netgen raises its own NgException
        print(str(exc).strip() or type(exc).__name__, file=sys.stderr)
        return 1
    verts = np.array(ng_mesh.Coordinates(), dtype=np.float64)
    tets = ng_mesh.Elements3D().NumPy()["nodes"][:, :4].astype(np.int64) - 1  # Netgen counts from 1
    np.savez(out, verts=verts, tets=tets)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
