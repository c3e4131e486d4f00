"""Big meshes for the scale measurements (issue 15): Newell's teapot
tessellated finely and written as binary PLY with per-vertex normals.

    python bench/make_big.py DETAIL OUT.ply     # 128: 1.05M triangles, 256: 4.19M, 685: 30.0M

64 x DETAIL^2 faces before the poles' degenerate ones are dropped at
load.  Deterministic: the same DETAIL writes the same bytes.
"""
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from raytrace.scene.teapot import tessellate  # noqa: E402


def write_ply(path, v, f, n):
    """Binary little-endian PLY: float32 x y z nx ny nz, int32 triangles."""
    vert = np.empty(len(v), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"),
                                   ("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")])
    for k, name in enumerate("xyz"):
        vert[name] = v[:, k]
        vert["n" + name] = n[:, k]
    face = np.empty(len(f), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    face["n"] = 3
    face["i"] = f
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(v)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              "property float nx\nproperty float ny\nproperty float nz\n"
              f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n")
    with open(path, "wb") as fh:
        fh.write(header.encode("ascii"))
        fh.write(vert.tobytes())
        fh.write(face.tobytes())


def main():
    detail, out = int(sys.argv[1]), Path(sys.argv[2])
    t0 = time.perf_counter()
    v, f, n = tessellate(detail)
    write_ply(out, v, f, n)
    print(f"{out}: {len(f):,} faces, {len(v):,} vertices, {out.stat().st_size / 1e6:.0f} MB "
          f"in {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
