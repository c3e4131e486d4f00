"""Issue 45 item 11, the API calls still answered with a bare exception or
accepted silently: each is now a RaytraceError naming the argument, or,
for a max_hits past any count, no limit."""
import numpy as np
import pytest

import raytrace
from raytrace import RayScene, RaytraceError
from raytrace.scene.model import Material

V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
F = np.array([[0, 1, 2]])
ORIGIN = np.array([[0.2, 0.2, 1.0]])
DIRECTION = np.array([[0, 0, -1.0]])


def test_a_max_hits_past_any_count_is_no_limit():
    rs = RayScene((V, F))
    assert rs.count_intersections(ORIGIN, DIRECTION, max_hits=10**30).tolist() == [1]
    assert len(rs.list_intersections(ORIGIN, DIRECTION, max_hits=10**30).t) == 1


@pytest.mark.parametrize("call, message", [
    (lambda rs: rs.cast_rays(ORIGIN, DIRECTION, t_max=np.array([5 + 1j])), r"t_max: complex numbers"),
    (lambda rs: rs.occluded(ORIGIN, DIRECTION, t_min=0.1 + 0j), r"t_min: complex numbers"),
    (lambda rs: rs.cast_rays(np.array([["2020-01-01"] * 3], dtype="datetime64[D]"), DIRECTION),
     r"origins: dates and times are not coordinates"),
    (lambda rs: rs.cast_rays(ORIGIN, np.array([[1, 2, 3]], dtype="timedelta64[s]")),
     r"directions: dates and times"),
    (lambda rs: RayScene((V.astype(complex), F)), r"vertices must be real numbers, got complex128"),
])
def test_complex_and_date_inputs_are_refused_by_name(call, message):
    with pytest.raises(RaytraceError, match=message):
        call(RayScene((V, F)))


@pytest.mark.parametrize("target", [None, "point cloud"])
def test_the_trimesh_intersector_wants_a_mesh(target):
    trimesh = pytest.importorskip("trimesh")
    from raytrace.cast.trimesh_ray import RayMeshIntersector
    if target == "point cloud":
        target = trimesh.PointCloud(V)
    with pytest.raises(RaytraceError, match=r"mesh: expected a mesh with \.vertices and \.faces"):
        RayMeshIntersector(target)
    RayMeshIntersector(trimesh.primitives.Box())     # faces made later: accepted


@pytest.mark.parametrize("material", [Material(color=(float("nan"), 0.5, 0.5)),
                                      Material(reflect=float("inf")), Material(ior="glass")])
def test_a_material_number_that_is_not_finite_is_named(material):
    scene = raytrace.load_scene("teapot", width=8, height=6)
    scene.objects[0].material = material
    with pytest.raises(RaytraceError, match=r"object 0 \(teapot\): its material has .* finite numbers"):
        raytrace.render(scene)
