"""The path tracer's record (kernels/render.Paths): its depth and its
emitters, the triangles whose material has an emission, with the running
sum of their areas for next-event estimation's area-weighted choice."""
import numpy as np

from raytrace.kernels.buffers import MAT_EMISSION, f64, i64
from raytrace.kernels.render import Paths


def path_record(geo, max_depth, strategy=0, roulette_depth=None, sampler="independent"):
    """Paths for the flattened scene ``geo``; strategy, roulette_depth and
    sampler (a name) as kernels/pathtrace.py defines them (MIS; its
    ROULETTE_DEPTH; SAMPLERS)."""
    from raytrace.kernels.pathtrace import ROULETTE_DEPTH, SAMPLERS
    glow = geo.mat_param[:, MAT_EMISSION:MAT_EMISSION + 3].sum(axis=1) > 0.0
    tri = np.flatnonzero(glow[geo.tri_mat]) if len(geo.tri_mat) else np.zeros(0, np.int64)
    e1 = geo.tri_v1[tri] - geo.tri_v0[tri]
    e2 = geo.tri_v2[tri] - geo.tri_v0[tri]
    area = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)
    tri, area = tri[area > 0.0], area[area > 0.0]
    total = float(area.sum())
    cdf = np.cumsum(area) / total if total > 0.0 else np.zeros(0)
    if len(cdf):
        cdf[-1] = 1.0
    else:
        tri, cdf = np.zeros(1, np.int64), np.ones(1)     # never read: emit_area 0
    return Paths(max_depth=int(max_depth), strategy=int(strategy),
                 roulette_depth=int(ROULETTE_DEPTH if roulette_depth is None else roulette_depth),
                 emit_tri=i64(tri), emit_cdf=f64(cdf), emit_area=total,
                 sampler=SAMPLERS[sampler])
