"""Write the textured example: assets/crate.obj with crate.mtl and its
image crate.png (a wooden crate, the image drawn here), and
assets/palette.ply (a ball coloured per vertex).  Run once; the files are
committed and assets/textured.toml places them.

    python bench/make_textured.py [--out DIR]
"""
from pathlib import Path

import click
import numpy as np

SIZE = 128   # texels along each side of crate.png


def crate_image(n=SIZE, seed=3):
    """(n, n, 3) uint8 sRGB: four planks with grain, a dark frame and a
    diagonal brace, and a red mark in the upper left corner (it shows
    which way up the texture lies)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:n, 0:n] / n
    plank = np.minimum((y * 4).astype(int), 3)
    tint = np.array([1.0, 0.92, 1.06, 0.96])[plank]
    grain = 0.08 * np.sin(2 * np.pi * (9 * y + 0.6 * np.sin(7 * x + plank))) + 0.04 * rng.random((n, n))
    wood = np.array([0.62, 0.42, 0.22])[None, None, :] * (tint + grain)[..., None]
    seam = np.abs(y * 4 - np.round(y * 4)) < 0.02
    wood[seam] *= 0.55
    frame = (x < 0.1) | (x > 0.9) | (y < 0.1) | (y > 0.9)
    brace = (np.abs(x - y) < 0.07) & ~frame
    wood[frame | brace] = wood[frame | brace] * 0.6 + np.array([0.18, 0.1, 0.04]) * 0.4
    mark = (x - 0.05) ** 2 + (y - 0.05) ** 2 < 0.03 ** 2
    wood[mark] = (0.75, 0.08, 0.06)
    return (np.clip(wood, 0, 1) * 255).round().astype(np.uint8)


def crate_obj(size=0.9, center=(-0.7, 0.45, 0.0)):
    """OBJ text of a box with the whole image on each face (4 vertices and
    texture coordinates per face, no normals: the renderer keeps the
    edges sharp by its crease angle)."""
    c = np.asarray(center)
    h = size / 2
    lines = ["# A wooden crate: bench/make_textured.py", "mtllib crate.mtl"]
    faces = []
    # Each face: its normal axis and sign, and two in-plane axes (u, v) with
    # u x v along the outward normal, so the image is upright and unmirrored.
    for axis, sign in ((0, 1), (0, -1), (1, 1), (1, -1), (2, 1), (2, -1)):
        n = np.zeros(3)
        n[axis] = sign
        up = np.array([0.0, 1.0, 0.0]) if axis != 1 else np.array([0.0, 0.0, -sign])
        u = np.cross(up, n)
        v = np.cross(n, u)
        base = len(faces) * 4
        for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            p = c + h * (n + su * u + sv * v)
            lines.append(f"v {p[0]:.6g} {p[1]:.6g} {p[2]:.6g}")
            lines.append(f"vt {(su + 1) / 2:g} {(sv + 1) / 2:g}")
        faces.append(base)
    lines.append("usemtl crate")
    for base in faces:
        a, b, cc, d = (base + k + 1 for k in range(4))
        lines.append(f"f {a}/{a} {b}/{b} {cc}/{cc}")
        lines.append(f"f {a}/{a} {cc}/{cc} {d}/{d}")
    return "\n".join(lines) + "\n"


MTL = """# The crate's material: bench/make_textured.py
newmtl crate
Kd 1 1 1
Ks 0.1 0.1 0.1
Ns 20
illum 2
map_Kd crate.png
"""


def palette_mesh(radius=0.55, center=(0.75, 0.55, 0.1), toward=(1.2, 1.9, 3.4)):
    """A ball with the hue wheel around the axis pointing at ``toward`` (the
    example's camera, which then sees every hue) and lighter along it, as
    8-bit sRGB vertex colours."""
    import colorsys

    import trimesh
    ball = trimesh.creation.icosphere(subdivisions=3, radius=radius)
    v = ball.vertices
    axis = np.subtract(toward, center)
    axis /= np.linalg.norm(axis)
    e1 = np.cross(axis, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    hue = (np.arctan2(v @ e2, v @ e1) / (2 * np.pi)) % 1.0
    light = 0.3 + 0.35 * (v @ axis / radius + 1) / 2
    rgb = np.array([colorsys.hls_to_rgb(h, lum, 0.8) for h, lum in zip(hue, light)])
    colors = np.column_stack([(rgb * 255).round(), np.full(len(v), 255)]).astype(np.uint8)
    ball.apply_translation(center)
    return trimesh.Trimesh(ball.vertices, ball.faces, vertex_colors=colors, process=False)


@click.command()
@click.option("--out", type=click.Path(file_okay=False, path_type=Path),
              default=Path(__file__).resolve().parent.parent / "assets")
def main(out):
    from PIL import Image
    Image.fromarray(crate_image()).save(out / "crate.png", optimize=True)
    (out / "crate.mtl").write_text(MTL)
    (out / "crate.obj").write_text(crate_obj())
    palette_mesh().export(out / "palette.ply", encoding="binary")
    click.echo(f"wrote crate.obj, crate.mtl, crate.png and palette.ply in {out}")


if __name__ == "__main__":
    main()
