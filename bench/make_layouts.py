"""The big teapot (bench/make_big.py) written in the file layouts users
have, for the mesh-reading benchmark (issue 43): files go to OUT_DIR (keep
them out of the repository; /tmp or bench-out/).

    python bench/make_layouts.py DETAIL OUT_DIR [NAME...]   # 128: 1.05M triangles, 256: 4.19M

Writes, each named teapot-DETAIL-LAYOUT.EXT:
  ply-plain   binary PLY, float x y z, uchar int triangles, no normals
              (trimesh's export: the common scan/export layout)
  ply-rich    big-endian PLY, double x y z, float nx ny nz, uchar red green
              blue, float s t, int count and uint indices, quads (and triangles
              where a pair is not one)
  obj         OBJ with v, vt, vn and f a/b/c corners (trimesh's export)
  obj-plain   OBJ of v lines and f a corners only (a scan's: shading is smoothed)
  stl         binary STL (a triangle soup: the reader welds it)
  stl-ascii   ASCII STL, coordinates as %e writes them
Deterministic: the same DETAIL writes the same bytes.
"""
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from raytrace.scene.teapot import tessellate  # noqa: E402


def ply_header(fmt, n_vertices, vertex_props, n_faces, count_type, index_type):
    props = "".join(f"property {t} {name}\n" for t, name in vertex_props)
    return (f"ply\nformat {fmt} 1.0\nelement vertex {n_vertices}\n{props}"
            f"element face {n_faces}\nproperty list {count_type} {index_type} vertex_indices\n"
            "end_header\n").encode("ascii")


def write_plain_ply(path, v, f):
    vert = np.ascontiguousarray(v, dtype="<f4")
    face = np.empty(len(f), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    face["n"], face["i"] = 3, f
    with open(path, "wb") as fh:
        fh.write(ply_header("binary_little_endian", len(v), [("float", c) for c in "xyz"],
                            len(f), "uchar", "int"))
        fh.write(vert.tobytes())
        fh.write(face.tobytes())


def write_rich_ply(path, v, f, n):
    """Big-endian, doubles, colours, texture coordinates, and the triangle
    pairs of each quad written as one quad where the file's order allows
    (the teapot's tessellation emits quad (a, d, b, c) as faces 2k =
    (a, b, c) and 2k + 1 = (a, d, b)): at these details every pair is one."""
    props = [("double", "x"), ("double", "y"), ("double", "z"), ("float", "nx"),
             ("float", "ny"), ("float", "nz"), ("uchar", "red"), ("uchar", "green"),
             ("uchar", "blue"), ("float", "s"), ("float", "t")]
    vert = np.empty(len(v), dtype=[(name, ">" + {"double": "f8", "float": "f4", "uchar": "u1"}[t])
                                   for t, name in props])
    for k, c in enumerate("xyz"):
        vert[c] = v[:, k]
        vert["n" + c] = n[:, k]
    lo, span = v.min(axis=0), np.ptp(v, axis=0) + 1e-12
    rgb = ((v - lo) / span * 255).astype(np.uint8)
    for k, c in enumerate(("red", "green", "blue")):
        vert[c] = rgb[:, k]
    vert["s"], vert["t"] = (v[:, 0] - lo[0]) / span[0], (v[:, 2] - lo[2]) / span[2]
    pairs = f[: len(f) // 2 * 2].reshape(-1, 2, 3)
    quad = (pairs[:, 0, 0] == pairs[:, 1, 0]) & (pairs[:, 0, 1] == pairs[:, 1, 2])
    quads = np.concatenate([pairs[quad][:, 1], pairs[quad][:, 0, 2:]], axis=1)
    tris = np.concatenate([pairs[~quad].reshape(-1, 3), f[len(f) // 2 * 2:]])
    with open(path, "wb") as fh:
        fh.write(ply_header("binary_big_endian", len(v), props, len(quads) + len(tris),
                            "int", "uint"))
        fh.write(vert.tobytes())
        q = np.empty(len(quads), dtype=[("n", ">i4"), ("i", ">u4", (4,))])
        q["n"], q["i"] = 4, quads
        t = np.empty(len(tris), dtype=[("n", ">i4"), ("i", ">u4", (3,))])
        t["n"], t["i"] = 3, tris
        fh.write(q.tobytes())
        fh.write(t.tobytes())


def write_obj(path, v, f, n):
    """v, vt, vn lines and f a/b/c corners, as trimesh and Blender write."""
    lo, span = v.min(axis=0), np.ptp(v, axis=0) + 1e-12
    uv = np.stack([(v[:, 0] - lo[0]) / span[0], (v[:, 2] - lo[2]) / span[2]], axis=1)
    with open(path, "w") as fh:
        fh.write("# teapot\n")
        np.savetxt(fh, v, fmt="v %.8g %.8g %.8g")
        np.savetxt(fh, uv, fmt="vt %.8g %.8g")
        np.savetxt(fh, n, fmt="vn %.6g %.6g %.6g")
        g = f + 1
        np.savetxt(fh, np.repeat(g, 3, axis=1), fmt="f %d/%d/%d %d/%d/%d %d/%d/%d")


def write_plain_obj(path, v, f):
    with open(path, "w") as fh:
        np.savetxt(fh, v, fmt="v %.8g %.8g %.8g")
        np.savetxt(fh, f + 1, fmt="f %d %d %d")


def facet_normals(tri):
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    return np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)


def write_ascii_stl(path, v, f):
    tri = v[f]
    rows = np.concatenate([facet_normals(tri), tri.reshape(-1, 9)], axis=1)
    facet = ("facet normal %e %e %e\n  outer loop\n" + "    vertex %e %e %e\n" * 3
             + "  endloop\nendfacet")
    with open(path, "w") as fh:
        fh.write("solid teapot\n")
        np.savetxt(fh, rows, fmt=facet)
        fh.write("endsolid teapot\n")


def write_stl(path, v, f):
    tri = v[f].astype("<f4")
    normal = facet_normals(tri)
    rec = np.zeros(len(f), dtype=[("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    rec["n"], rec["v"] = normal, tri
    with open(path, "wb") as fh:
        fh.write(b"teapot".ljust(80, b" "))
        fh.write(np.uint32(len(f)).tobytes())
        fh.write(rec.tobytes())


NAMES = ("ply-plain.ply", "ply-rich.ply", "obj.obj", "obj-plain.obj", "stl.stl", "stl-ascii.stl")


def main():
    detail, out = int(sys.argv[1]), Path(sys.argv[2])
    only = sys.argv[3:]
    out.mkdir(parents=True, exist_ok=True)
    v, f, n = tessellate(detail)
    for name, write in (("ply-plain.ply", lambda p: write_plain_ply(p, v, f)),
                        ("ply-rich.ply", lambda p: write_rich_ply(p, v, f, n)),
                        ("obj.obj", lambda p: write_obj(p, v, f, n)),
                        ("obj-plain.obj", lambda p: write_plain_obj(p, v, f)),
                        ("stl.stl", lambda p: write_stl(p, v, f)),
                        ("stl-ascii.stl", lambda p: write_ascii_stl(p, v, f))):
        if only and name not in only:
            continue
        t0 = time.perf_counter()
        path = out / f"teapot-{detail}-{name}"
        write(path)
        print(f"{path}: {len(f):,} faces, {path.stat().st_size / 1e6:.0f} MB "
              f"in {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
