"""What a Dask worker receives for a scene: the render's buffers
(``Setup.payload()``: the flattened scene, the structure, the lights),
pickled as frames/distributed.py scatters them.  The cluster estimate in docs/benchmarks.md
takes its "MB of buffers per worker" from here.

    python bench/payload.py [SCENE] [--detail N] [--accel bvh] [--shadows soft]
"""
import pickle

import click


@click.command()
@click.argument("scene", default="teapot")
@click.option("--detail", type=int, default=256)
@click.option("--accel", default="bvh")
@click.option("--shadows", default="soft")
def main(scene, detail, accel, shadows):
    import raytrace
    from raytrace.renderer.driver import options_with, prepare
    sc = raytrace.load_scene(scene, detail=detail)
    setup = prepare(sc, options_with(None, dict(accel=accel, shadows=shadows)), drop_meshes=True)
    size = len(pickle.dumps(setup.payload(), protocol=pickle.HIGHEST_PROTOCOL))
    n = setup.geo.tri_v0.shape[0]
    click.echo(f"{scene} --detail {detail} ({accel}): {n:,} triangles, payload {size / 1e6:,.1f} MB "
               f"pickled, {size / max(n, 1):,.0f} bytes a triangle")


if __name__ == "__main__":
    main()
