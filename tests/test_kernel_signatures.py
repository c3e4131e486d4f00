"""One compiled version of each kernel per structure and mode, whatever
types the caller passes: a NumPy integer for a size, a read-only, float32
or Fortran-ordered ray array must be normalised by the Python layer, not
compile the kernels again (each compile costs seconds and disk)."""
import json
import subprocess
import sys

SCRIPT = r"""
import json
import numpy as np
import raytrace
from raytrace.renderer.driver import render
from raytrace.scene.builtin import spheres

sc = spheres()
for kw in (dict(width=16, height=12),
           dict(width=np.int32(16), height=np.int64(12), spp=np.int16(1), seed=np.uint8(0)),
           dict(width=16, height=12, threads=np.int32(1))):
    render(sc, accel="bvh", shadows="hard", **kw)
render(sc, accel="bvh", shadows="hard", width=16, height=12, aov=True)
render(sc, accel="bvh", shadows="hard", width=16, height=12, aov=np.bool_(True))

v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
f = np.array([[0, 1, 2]], np.int32)
o = np.array([[0.2, 0.2, 1.0], [0.3, 0.3, 1.0]])
d = np.array([[0, 0, -1.0], [0, 0, -1.0]])
ro_o, ro_d = o.copy(), d.copy()
ro_o.setflags(write=False)
ro_d.setflags(write=False)
for oo, dd, tm in ((o, d, None), (ro_o, ro_d, None), (o.astype(np.float32), d.astype(np.float32), None),
                   (np.asfortranarray(o), np.asfortranarray(d), np.float32(5)), (o.tolist(), d.tolist(), 5),
                   (o[::1, :], d[:, :], np.array([5, 6], np.int64))):
    h = raytrace.cast_rays((v, f), oo, dd, t_max=tm)
    assert h.hit.all()
    assert raytrace.occluded((v, f), oo, dd, 2 if tm is None else tm).all()

from raytrace.accel.bvh.collapse import collapse_bvh4_kernel

from raytrace.accel.bvh.sah import build_bvh_kernel
from raytrace.kernels import cast
from raytrace.kernels.wavefront import run_stage
kernels = dict(run_stage=run_stage, closest=cast._closest_single,
               occluded=cast._occluded_single, build_bvh_kernel=build_bvh_kernel,
               collapse_bvh4_kernel=collapse_bvh4_kernel,
               packets=cast._closest_block, occluded_packets=cast._occluded_block)
out = {k: [str(s) for s in f.signatures] for k, f in kernels.items()}
# Every structure's queries, for the literal check below.
for accel in ("none", "bvol", "grid", "kdtree", "bvh"):
    s = raytrace.RayScene((v, f), accel=accel)
    assert s.cast_rays(o, d).hit.all() and s.count_intersections(o, d).tolist() == [1, 1]
    assert len(s.list_intersections(o, d).t) == 2
# Helpers compiled for a literal integer argument (a ``0`` where an int64
# variable would do) are compiled twice, once for the literal.
import gc
from numba.core.registry import CPUDispatcher
literal = sorted({f"{d.py_func.__module__}.{d.py_func.__qualname__}"
                  for d in gc.get_objects() if isinstance(d, CPUDispatcher)
                  and d.py_func.__module__.startswith("raytrace")
                  for s in d.signatures if "Literal[int]" in str(s)})
print(json.dumps(dict(out, literal=literal)))
"""


def test_one_signature_per_structure_and_mode():
    p = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr[-2000:]
    sigs = json.loads(p.stdout.strip().splitlines()[-1])
    # The shading stages: one kernel with and without AOVs (and for every
    # structure: their types hold none).
    assert len(sigs["run_stage"]) == 1, sigs["run_stage"]
    for name in ("closest", "occluded", "build_bvh_kernel", "collapse_bvh4_kernel"):
        assert len(sigs[name]) == 1, (name, sigs[name])
    # Renders, with AOVs or without, trace through the packet kernels (as a
    # RayScene call of many rays does), one version of each; the calls of a
    # few rays (kernels/cast.py's PACKET_MIN) go through the one-ray
    # kernels (the one signature each checked above).
    assert len(sigs["packets"]) == 1, sigs["packets"]
    assert len(sigs["occluded_packets"]) == 1, sigs["occluded_packets"]
    # No helper compiled again for a literal integer argument: the packet
    # traversal was compiled twice in every first render (0.5 s).
    assert sigs["literal"] == [], sigs["literal"]
