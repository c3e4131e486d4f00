import pytest

from raytrace.driver import render
from raytrace.scenes.builtin import spheres, teapot

# Small images keep the suite fast once the kernels are compiled; the
# teapot still covers a few thousand pixels.
W, H = 96, 72


@pytest.fixture(scope="session")
def teapot_scene():
    return teapot()


@pytest.fixture(scope="session")
def spheres_scene():
    return spheres()


@pytest.fixture(scope="session")
def render_small():
    cache = {}

    def go(scene, **kw):
        key = (scene.name, tuple(sorted(kw.items())))
        if key not in cache:
            kw.setdefault("width", W)
            kw.setdefault("height", H)
            cache[key] = render(scene, **kw)
        return cache[key]
    return go
