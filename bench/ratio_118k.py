"""Scaling through the renderer: how much dearer a ray is on the 118k-triangle
teapot (``--detail 43``) than on the 1k one, through the renderer.

640x480, BVH, 2 threads; for each shadow mode the two scenes are rendered in
turn, 11 rounds after a warm-up each, and the median render times compared
per ray (the kernel's wall time: compile and build excluded).  bench.sh's
scaling table measures the same with hard shadows over five sizes; the
peer table has the kernel-level figure (camera rays alone, no shading).

    PYTHONPATH=. python bench/ratio_118k.py
"""
import statistics

from raytrace.renderer.driver import render
from raytrace.scene.builtin import teapot

ROUNDS = 11


def main():
    scenes = {d: teapot(detail=d) for d in (4, 43)}
    for shadows in ("none", "hard"):
        for scene in scenes.values():
            render(scene, shadows=shadows)  # warm-up: kernel load, builders
        times = {d: [] for d in scenes}
        rays = {}
        for _ in range(ROUNDS):
            for d, scene in scenes.items():
                r = render(scene, shadows=shadows)
                times[d].append(r.stats["time"]["render_s"])
                rays[d] = r.stats["derived"]["rays"]
        med = {d: statistics.median(ts) for d, ts in times.items()}
        tris = {d: render(s, shadows="none", width=8, height=6).stats["triangles"]
                for d, s in scenes.items()}
        ratio = (med[43] / rays[43]) / (med[4] / rays[4])
        print(f"shadows={shadows}: {tris[4]:,} triangles {med[4]:.4f} s "
              f"({rays[4] / med[4] / 1e6:.1f} Mrays/s), {tris[43]:,} triangles {med[43]:.4f} s "
              f"({rays[43] / med[43] / 1e6:.1f} Mrays/s); per-ray cost ratio {ratio:.2f}")


if __name__ == "__main__":
    main()
