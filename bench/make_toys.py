"""Write assets/toys.obj and assets/toys.mtl: four coloured shapes made
with trimesh.creation, one material each, no vertex normals (so the
renderer smooths them, keeping the box's and the cylinder's rims sharp).
Run once; the files are committed.

    python bench/make_toys.py [--out DIR]
"""
from pathlib import Path

import click
import numpy as np

# name: (Kd, Ks, Ns) -- linear RGB, a grey highlight, its sharpness.
MATERIALS = {
    "red_box": ((0.70, 0.10, 0.08), 0.25, 20),
    "blue_can": ((0.08, 0.22, 0.65), 0.6, 80),
    "yellow_ball": ((0.85, 0.60, 0.08), 0.8, 150),
    "green_ring": ((0.12, 0.50, 0.18), 0.4, 40),
}


def shapes():
    """(material, trimesh) pairs, y-up, standing on y = 0."""
    import trimesh
    from trimesh.transformations import rotation_matrix, translation_matrix
    up = rotation_matrix(-np.pi / 2, [1, 0, 0])            # trimesh's z-up shapes to y-up
    box = trimesh.creation.box([0.8, 0.8, 0.8])
    box.apply_transform(translation_matrix([-1.1, 0.4, -0.2]) @ rotation_matrix(0.5, [0, 1, 0]))
    can = trimesh.creation.cylinder(radius=0.4, height=1.2, sections=32)
    can.apply_transform(translation_matrix([0.0, 0.6, -0.5]) @ up)
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.45)
    ball.apply_transform(translation_matrix([1.1, 0.45, -0.1]))
    ring = trimesh.creation.torus(0.35, 0.12, major_sections=32, minor_sections=16)
    ring.apply_transform(translation_matrix([0.1, 0.12, 0.7]) @ up)
    return [("red_box", box), ("blue_can", can), ("yellow_ball", ball), ("green_ring", ring)]


def obj_text(parts):
    lines = ["# Four coloured shapes (bench/make_toys.py), one material each in toys.mtl;",
             "# no vertex normals: the renderer smooths them up to its crease angle.",
             "mtllib toys.mtl"]
    offset = 1
    for name, mesh in parts:
        lines.append(f"o {name}")
        lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in mesh.vertices]
        lines.append(f"usemtl {name}")
        lines += [f"f {a + offset} {b + offset} {c + offset}" for a, b, c in mesh.faces]
        offset += len(mesh.vertices)
    return "\n".join(lines) + "\n"


def mtl_text():
    lines = ["# Materials of toys.obj (bench/make_toys.py)."]
    for name, (kd, ks, ns) in MATERIALS.items():
        lines += ["", f"newmtl {name}", "Kd {:.2f} {:.2f} {:.2f}".format(*kd),
                  f"Ks {ks:.2f} {ks:.2f} {ks:.2f}", f"Ns {ns}", "illum 2"]
    return "\n".join(lines) + "\n"


@click.command()
@click.option("--out", type=click.Path(file_okay=False, path_type=Path),
              default=Path(__file__).resolve().parents[1] / "assets", show_default=True)
def main(out):
    (out / "toys.obj").write_text(obj_text(shapes()))
    (out / "toys.mtl").write_text(mtl_text())
    print(f"wrote {out / 'toys.obj'} and {out / 'toys.mtl'}")


if __name__ == "__main__":
    main()
