"""A glTF scene of several meshes, primitives and node transforms (issue
43): every primitive of every node that uses it is a part, placed by the
node's world transform (parents' too), mirrored ones wound back."""
import base64
import json

import numpy as np

from raytrace.scene.formats.mesh import read_mesh, read_mesh_parts

TRI_A = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
TRI_B = np.array([[0, 0, 1], [1, 0, 1], [0, 1, 1]], np.float32)
QUAD = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
QUAD_FACES = np.array([[0, 1, 2], [0, 2, 3]], np.uint16)
S = np.sqrt(0.5)


def gltf_scene():
    """A .gltf (buffer inline): mesh 0 two primitives (TRI_A, TRI_B), mesh
    1 the quad; node 0 translated with children 1 (mesh 0, scaled) and 2
    (mesh 1, turned 90 degrees about z); root nodes 3 (mesh 1 again,
    translated) and 4 (mesh 1 mirrored in x)."""
    blobs = [TRI_A.tobytes(), TRI_B.tobytes(), QUAD.tobytes(), QUAD_FACES.tobytes()]
    offsets = np.cumsum([0] + [len(b) for b in blobs])
    data = b"".join(blobs)
    views = [{"buffer": 0, "byteOffset": int(o), "byteLength": len(b)} for o, b in zip(offsets, blobs)]

    def accessor(view, count, kind, ctype=5126, points=None):
        out = {"bufferView": view, "componentType": ctype, "count": count, "type": kind}
        if points is not None:
            out.update(min=points.min(axis=0).tolist(), max=points.max(axis=0).tolist())
        return out
    accessors = [accessor(0, 3, "VEC3", points=TRI_A), accessor(1, 3, "VEC3", points=TRI_B),
                 accessor(2, 4, "VEC3", points=QUAD), accessor(3, 6, "SCALAR", 5123)]
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(data),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
        "bufferViews": views, "accessors": accessors,
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}},
                                   {"attributes": {"POSITION": 1}}]},
                   {"primitives": [{"attributes": {"POSITION": 2}, "indices": 3}]}],
        "nodes": [{"translation": [10, 0, 0], "children": [1, 2]},
                  {"mesh": 0, "scale": [2, 2, 2]},
                  {"mesh": 1, "rotation": [0, 0, S, S]},
                  {"mesh": 1, "translation": [0, 5, 0]},
                  {"mesh": 1, "scale": [-1, 1, 1]}],
        "scenes": [{"nodes": [0, 3, 4]}], "scene": 0,
    }
    return json.dumps(doc)


def expected_triangles():
    """Each placed triangle's corners, worked out here."""
    quad = QUAD[QUAD_FACES.astype(int)].astype(float)
    turn = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]], float)
    mirrored = quad * [-1, 1, 1]
    return [2 * TRI_A[None].astype(float) + [10, 0, 0], 2 * TRI_B[None].astype(float) + [10, 0, 0],
            quad @ turn.T + [10, 0, 0], quad + [0, 5, 0], mirrored]


def test_every_node_and_primitive_is_placed(tmp_path):
    path = tmp_path / "scene.gltf"
    path.write_text(gltf_scene())
    parts = read_mesh_parts(path)
    def corner_sets(triangles):      # the winding is checked below
        return sorted(sorted(map(tuple, t)) for ts in triangles for t in np.round(ts, 9).tolist())
    assert len(parts) == 5
    assert corner_sets(p.vertices[p.faces] for p in parts) == corner_sets(expected_triangles())
    # The mirrored quad is wound back: its faces still face +z, as the quad's do.
    for p in parts:
        tri = p.vertices[p.faces]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        assert (normal[:, 2] > 0).all()
    v, f = read_mesh(path)
    assert len(f) == 1 + 1 + 2 + 2 + 2 and len(v) == 3 + 3 + 4 + 4 + 4
