"""Per-vertex arrays (colours, texture coordinates) follow the vertices
through the crease split (normals.crease_split's ``source`` map), and the
split agrees with a slow, obvious reference (issue 45, item 2)."""
import math

import numpy as np
import pytest
import trimesh
from click.testing import CliRunner

from raytrace.cli.main import main
from raytrace.scene.creases import SMALL_FAN
from raytrace.scene.formats.mesh import part_mesh, read_mesh_parts
from raytrace.scene.model import Material
from raytrace.scene.normals import crease_split, face_normals


def reference_groups(v, f, crease, keep):
    """For each corner, a label shared by exactly the corners that become
    one output vertex: same position, joined through shared edges of
    faces within the crease angle, and (keep) the same vertex index."""
    pos = {}
    pid = [pos.setdefault(tuple(p), len(pos)) for p in v.tolist()]
    fn = face_normals(v, f)
    cos = math.cos(math.radians(crease))
    corners = 3 * len(f)
    parent = list(range(corners))

    def find(i):
        while parent[i] != i:
            i = parent[i]
        return i
    for c1 in range(corners):
        for c2 in range(c1):
            f1, f2 = c1 // 3, c2 // 3
            p1, p2 = pid[f[f1, c1 % 3]], pid[f[f2, c2 % 3]]
            if f1 == f2 or p1 != p2:
                continue
            others1 = {pid[f[f1, (c1 % 3 + k) % 3]] for k in (1, 2)}
            others2 = {pid[f[f2, (c2 % 3 + k) % 3]] for k in (1, 2)}
            if others1 & others2 and fn[f1] @ fn[f2] >= cos:
                parent[find(c1)] = find(c2)
    return [(find(c), f[c // 3, c % 3] if keep else -1) for c in range(corners)]


def partition(labels):
    """The corners' classes as a set of frozensets."""
    classes = {}
    for c, label in enumerate(labels):
        classes.setdefault(label, set()).add(c)
    return {frozenset(s) for s in classes.values()}


def awkward_mesh(seed):
    """A cone with a wide apex fan (the sorted path), a seam of repeated
    positions, a degenerate face and an edge shared by three faces."""
    rng = np.random.default_rng(seed)
    k = SMALL_FAN + 9
    ring = np.stack([np.cos(np.linspace(0, 2 * np.pi, k, endpoint=False)),
                     np.sin(np.linspace(0, 2 * np.pi, k, endpoint=False)), np.zeros(k)], 1)
    ring[:, 2] += rng.normal(scale=0.3, size=k)
    v = np.concatenate([[[0.0, 0.0, 1.0]], ring, ring[:1], [[0.0, 0.0, -1.0], [2.0, 0.0, 0.5]]])
    seam = k + 1                                   # the first ring vertex repeated
    faces = [[0, 1 + i, 1 + (i + 1) % k] for i in range(k - 1)] + [[0, k, seam]]
    faces += [[k + 2, 1 + (i + 1) % k, 1 + i] for i in range(k)]
    faces += [[0, 1, k + 3], [0, 0, 1]]            # a third face on edge (0, 1); no area
    return v, np.array(faces)


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("crease", [0, 35, 180])
@pytest.mark.parametrize("keep", [False, True])
def test_split_matches_the_reference(seed, crease, keep):
    v, f = awkward_mesh(seed)
    source, f2, n = crease_split(v, f, crease, keep=keep)
    assert np.array_equal(v[source][f2], v[f])            # the same triangles, bit for bit
    if keep:
        assert np.array_equal(source[f2], f)              # every corner keeps its vertex
    assert partition(f2.ravel()) == partition(reference_groups(v, f, crease, keep))
    # Unit normals; the face without area joins its neighbours at crease
    # 180 (a zero normal is within any angle), else has zero ones (the
    # renderer then takes the face's own).
    area = face_normals(v, f).any(axis=1)
    assert np.isfinite(n).all() and np.allclose(np.linalg.norm(n[f2[area]], axis=2), 1)
    assert np.allclose(np.linalg.norm(n[f2[~area]], axis=2), 1 if crease == 180 else 0)


def test_keeping_vertices_apart_changes_no_normal():
    v, f = awkward_mesh(3)
    s1, f1, n1 = crease_split(v, f, 35)
    s2, f2, n2 = crease_split(v, f, 35, keep=True)
    assert len(s2) > len(s1)                              # the seam stays apart
    assert np.array_equal(n1[f1], n2[f2])


def cube_obj_with_colours():
    box = trimesh.creation.box()
    lines = [f"v {x} {y} {z} {(x + .5):g} {(y + .5):g} {(z + .5):g}" for x, y, z in box.vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in box.faces]
    return "\n".join(lines) + "\n"


def write_case(tmp_path, case):
    """A file of each layout the issue found failing; its path."""
    if case == "obj-vertex-colours":
        path = tmp_path / "cube.obj"
        path.write_text(cube_obj_with_colours())
    elif case in ("ply-vertex-colours", "ply-cylinder-colours"):
        mesh = (trimesh.creation.box() if case == "ply-vertex-colours"
                else trimesh.creation.cylinder(radius=1.0, height=2.0, sections=16))
        rgb = (np.asarray(mesh.vertices) - mesh.vertices.min(0)) / np.ptp(mesh.vertices, 0)
        mesh.visual.vertex_colors = np.c_[(rgb * 255).astype(np.uint8), np.full(len(rgb), 255)]
        path = tmp_path / f"{case}.ply"
        mesh.export(path)
    else:                                                 # textured, with a uv seam
        from PIL import Image
        Image.fromarray(np.arange(48, dtype=np.uint8).reshape(4, 4, 3)).save(tmp_path / "t.png")
        (tmp_path / "t.mtl").write_text("newmtl m\nKd 1 1 1\nmap_Kd t.png\n")
        mesh = (trimesh.creation.box() if case == "obj-textured-cube"
                else trimesh.creation.cylinder(radius=1.0, height=2.0, sections=16))
        v = np.asarray(mesh.vertices)[np.asarray(mesh.faces)].reshape(-1, 3)
        # A texture coordinate per corner: the same position carries several.
        uv = np.stack([np.arctan2(v[:, 1], v[:, 0]) / (2 * np.pi) + 0.5, v[:, 2] / 2 + 0.5], 1)
        uv[:, 0] += np.repeat(np.arange(len(mesh.faces)) % 3, 3) * 0.01
        lines = ["mtllib t.mtl", "usemtl m"] + [f"v {x!r} {y!r} {z!r}" for x, y, z in v.tolist()]
        lines += [f"vt {s!r} {t!r}" for s, t in uv.tolist()]
        lines += [f"f {3 * i + 1}/{3 * i + 1} {3 * i + 2}/{3 * i + 2} {3 * i + 3}/{3 * i + 3}"
                  for i in range(len(mesh.faces))]
        path = tmp_path / f"{case}.obj"
        path.write_text("\n".join(lines) + "\n")
    return path


CASES = ["obj-vertex-colours", "ply-vertex-colours", "ply-cylinder-colours", "obj-textured-cube",
         "obj-textured-cylinder"]


@pytest.mark.parametrize("case", CASES)
def test_attributes_follow_the_crease_split(tmp_path, case):
    path = write_case(tmp_path, case)
    (part,) = read_mesh_parts(path)
    attrs = [a for a in ("colors", "uv") if getattr(part, a) is not None]
    assert attrs                                          # the file's colours or uvs were read
    for crease in (0, 35, 180):
        mesh = part_mesh(part, Material(), crease, False, str(path))
        assert np.array_equal(mesh.vertices[mesh.faces], part.vertices[part.faces])
        for a in attrs:
            assert np.array_equal(getattr(mesh, a)[mesh.faces], getattr(part, a)[part.faces])
        if crease == 35:                                  # split: more vertices than positions
            assert len(np.unique(mesh.faces)) > len(np.unique(part.vertices, axis=0))


@pytest.mark.parametrize("case", CASES)
def test_attribute_files_render(tmp_path, case):
    path = write_case(tmp_path, case)
    out = tmp_path / "out.png"
    result = CliRunner().invoke(main, [str(path), "--width", "16", "--height", "12", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert out.stat().st_size > 0
