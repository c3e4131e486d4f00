"""Writes the teaching scenes of assets/: the teapot in a stadium and a
field of objects of very different sizes.  Deterministic: run it again
and the files come out byte for byte the same.

    python bench/make_scenes.py        # rewrites assets/stadium.* and assets/sizes.toml

Teapot in a stadium (Haines 1988, "Spline surface rendering, and what's
wrong with octrees"): a detailed small object inside a large, mostly
empty scene.  A uniform grid sizes its cells to the whole scene, so the
teapot's thousands of triangles fall into a handful of cells and every ray
near it tests them all; a hierarchy subdivides where the triangles are.
"""
import math
from pathlib import Path

import numpy as np

ASSETS = Path(__file__).resolve().parent.parent / "assets"

# The stands: an elliptical ring of stepped tiers around the field.
SEGMENTS = 72          # around the ring
TIERS = 8              # steps from the field's edge outwards and up
INNER = (45.0, 30.0)   # the field's semi-axes (x, z)
DEPTH = 3.0            # each tier's tread
RISE = 2.0             # each tier's height


def stadium_mesh():
    """(vertices, faces) of the stands: per segment and tier, a riser and
    a tread, as quads split into triangles."""
    verts, faces = [], []

    def point(a, tier, top):
        s = tier * DEPTH
        return (math.cos(a) * (INNER[0] + s), tier * RISE + (RISE if top else 0.0),
                math.sin(a) * (INNER[1] + s))

    def quad(p0, p1, p2, p3):
        k = len(verts)
        verts.extend([p0, p1, p2, p3])
        faces.extend([(k, k + 1, k + 2), (k, k + 2, k + 3)])

    for i in range(SEGMENTS):
        a0, a1 = 2 * math.pi * i / SEGMENTS, 2 * math.pi * (i + 1) / SEGMENTS
        for t in range(TIERS):
            # Riser: facing the field, from this tier's floor to its top.
            quad(point(a0, t, False), point(a1, t, False), point(a1, t, True), point(a0, t, True))
            # Tread: this tier's top, out to the next tier's riser.
            quad(point(a0, t, True), point(a1, t, True), point(a1, t + 1, False),
                 point(a0, t + 1, False))
    return np.array(verts), np.array(faces)


def write_obj(path, vertices, faces, comment):
    lines = [f"# {comment}", "# written by bench/make_scenes.py"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")


STADIUM_TOML = '''\
# The teapot in a stadium (Haines 1988): a detailed teapot (detail 12,
# 9,216 triangles) on a field ringed by stands 90 m across.  The grid sizes
# its cells to the stands, so the teapot lands in a few crowded cells:
# compare `raytrace compare assets/stadium.toml --accel bvh,grid,kdtree`.
# Written by bench/make_scenes.py.
name = "stadium"
description = "teapot in a stadium: a small detailed object in a large, mostly empty scene"

[camera]
position = [5.5, 4.0, 9.5]
look_at = [0.0, 2.0, 0.0]
fov = 55

[materials.body]
color = [0.80, 0.22, 0.12]
specular = 0.5
shininess = 48

[materials.stands]
color = [0.55, 0.57, 0.62]
specular = 0.1
shininess = 8

[materials.field]
color = [0.30, 0.55, 0.28]
ambient = 0.15
specular = 0.0
checker = 5.0

[[lights]]
type = "area"
position = [-20.0, 60.0, 25.0]
size = 12.0

[[objects]]
type = "teapot"
detail = 12
material = "body"

[[objects]]
type = "mesh"
file = "stadium.obj"
material = "stands"

[[objects]]
type = "plane"
material = "field"
'''


def sizes_toml(seed=7):
    """A big sphere, a teapot and hundreds of pebbles from 3 cm to 30 cm:
    sizes over three orders of magnitude in one scene."""
    rng = np.random.default_rng(seed)
    out = ['''\
# Objects of very different sizes: a sphere 16 m across, a teapot, 24
# boulders and 400 pebbles (3 cm to 30 cm, log-uniform).  A structure must
# adapt to density: the pebbles crowd the foreground, the big sphere fills
# the background with one primitive.  Written by bench/make_scenes.py.
name = "sizes"
description = "objects of very different sizes: pebbles, boulders, a teapot, a giant sphere"

[camera]
position = [0.0, 3.5, 12.0]
look_at = [0.0, 0.8, 0.0]
fov = 45

[materials.body]
color = [0.80, 0.22, 0.12]
specular = 0.5
shininess = 48

[materials.stone]
color = [0.55, 0.52, 0.48]
specular = 0.2
shininess = 16

[materials.giant]
color = [0.25, 0.35, 0.65]
specular = 0.3

[materials.ground]
color = [0.75, 0.75, 0.72]
ambient = 0.15
specular = 0.0
checker = 1.0

[[lights]]
type = "area"
position = [-6.0, 12.0, 8.0]
size = 4.0

[[objects]]
type = "teapot"
detail = 6
material = "body"

[[objects]]
type = "sphere"
center = [6.0, 8.0, -30.0]
radius = 8.0
material = "giant"

[[objects]]
type = "plane"
material = "ground"
''']

    def sphere(r, spread):
        while True:
            x, z = rng.uniform(-spread, spread, 2)
            if math.hypot(x, z * 1.5) > 1.8 and z < 3.5:   # clear of the teapot and camera
                break
        out.append(f'''
[[objects]]
type = "sphere"
center = [{x:.4f}, {r:.4f}, {z:.4f}]
radius = {r:.4f}
material = "stone"
''')
    for _ in range(24):
        sphere(float(rng.uniform(0.3, 0.8)), 6.0)
    for _ in range(400):
        sphere(float(math.exp(rng.uniform(math.log(0.03), math.log(0.3)))), 4.5)
    return "".join(out)


def main(dest=ASSETS):
    dest = Path(dest)
    v, f = stadium_mesh()
    write_obj(dest / "stadium.obj", v, f,
              f"stands of a stadium: {SEGMENTS} segments x {TIERS} tiers, {len(f)} triangles")
    (dest / "stadium.toml").write_text(STADIUM_TOML)
    (dest / "sizes.toml").write_text(sizes_toml())
    print(f"wrote {dest / 'stadium.obj'} ({len(f)} triangles), stadium.toml, sizes.toml")


if __name__ == "__main__":
    main()
