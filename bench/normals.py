"""Time of smooth vertex normals with creases (raytrace/scene/normals.py) on
meshes of about a million triangles: a smooth one (a torus: no vertex is
split), a creased one (a box of 1M triangles: every edge of the box is a
crease) and a noisy one (the torus with its vertices jittered by a fifth
of an edge, so creases are everywhere).  Best of --repeat runs.

    python bench/normals.py [--triangles N] [--repeat R]
"""
import time

import click
import numpy as np


def torus(triangles):
    import trimesh
    k = int(np.sqrt(triangles / 2))
    return trimesh.creation.torus(1.0, 0.3, major_sections=k, minor_sections=k)


def tessellated_box(triangles):
    """A unit box whose six sides are grids, about ``triangles`` in all."""
    import trimesh
    k = max(1, int(np.sqrt(triangles / 12)))
    g = np.linspace(-0.5, 0.5, k + 1)
    uu, vv = np.meshgrid(g, g, indexing="ij")
    idx = np.arange((k + 1) ** 2).reshape(k + 1, k + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    grid_faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    verts, faces = [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            p = np.zeros((uu.size, 3))
            p[:, axis] = 0.5 * sign
            p[:, (axis + 1) % 3], p[:, (axis + 2) % 3] = uu.ravel(), vv.ravel()
            f = grid_faces if sign > 0 else grid_faces[:, ::-1]
            faces.append(f + sum(len(x) for x in verts))
            verts.append(p)
    mesh = trimesh.Trimesh(np.concatenate(verts), np.concatenate(faces), process=False)
    mesh.merge_vertices()   # the sides share their edges' vertices
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


@click.command()
@click.option("--triangles", default=1_000_000, show_default=True)
@click.option("--repeat", default=3, show_default=True)
def main(triangles, repeat):
    from raytrace.scene.normals import crease_normals
    t = torus(triangles)
    v, f = np.asarray(t.vertices), np.asarray(t.faces)
    edge = np.linalg.norm(v[f[0, 0]] - v[f[0, 1]])
    noisy = v + np.random.default_rng(0).normal(scale=edge / 5, size=v.shape)
    cases = {"smooth torus": (v, f), "box, creased edges": tessellated_box(triangles),
             "noisy torus": (noisy, f)}
    for name, (verts, faces) in cases.items():
        best = float("inf")
        for _ in range(repeat):
            start = time.perf_counter()
            out_v, _, _ = crease_normals(verts, faces)
            best = min(best, time.perf_counter() - start)
        print(f"{name:<20} {len(faces):>9,} triangles  {len(verts):>9,} -> {len(out_v):>9,} "
              f"vertices  {best:.3f} s")


if __name__ == "__main__":
    main()
