"""A mesh's own colours: per-vertex colours and base-colour image textures.

A triangle's colour is its material's colour, times its vertex colours
interpolated by the hit's barycentrics, times its material's texture at the
interpolated texture coordinates: the products glTF specifies for
baseColorFactor, COLOR_0 and baseColorTexture, and MTL for Kd and map_Kd.
Compiled only for scenes that have them (``MeshTextures`` in render.py);
there ``Geometry.vtx_color`` or ``vtx_uv`` may still be empty, when no
mesh has colours, or none has a texture.

Texture coordinates follow OBJ: (0, 0) is the image's lower left corner,
and the texture repeats outside [0, 1).  Texels are linear RGB, rows stored
top row first, each texture at its offset in one ``tex_rgb`` array; a
material's ``mat_tex`` row is its texture's (offset, width, height).
"""
import numpy as np
from numba import njit

from raytrace.kernels.jit import JIT


@njit(**JIT)
def texture_rgb(geo, mat, s, t, bilinear):
    """Material ``mat``'s texture at (s, t): the nearest texel, or the
    bilinear blend of the four around it (texel centres at (i + 0.5) /
    width).  Texels in column i, row j counted from the bottom, both
    wrapped (Python's modulo: never negative); written out in one function
    (each compiled function has a fixed cost)."""
    off, w, h = geo.mat_tex[mat, 0], geo.mat_tex[mat, 1], geo.mat_tex[mat, 2]
    rgb = geo.tex_rgb
    # The fraction first, so a huge coordinate cannot overflow an integer.
    x = (s - np.floor(s)) * w
    y = (t - np.floor(t)) * h
    if not bilinear:
        k = off + (h - 1 - int(y) % h) * w + int(x) % w
        return rgb[k, 0], rgb[k, 1], rgb[k, 2]
    x -= 0.5
    y -= 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = x - x0, y - y0
    i0, j0 = int(x0) % w, int(y0) % h
    i1, j1 = (int(x0) + 1) % w, (int(y0) + 1) % h
    k00 = off + (h - 1 - j0) * w + i0
    k10 = off + (h - 1 - j0) * w + i1
    k01 = off + (h - 1 - j1) * w + i0
    k11 = off + (h - 1 - j1) * w + i1
    w00, w10, w01, w11 = (1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy
    return (w00 * rgb[k00, 0] + w10 * rgb[k10, 0] + w01 * rgb[k01, 0] + w11 * rgb[k11, 0],
            w00 * rgb[k00, 1] + w10 * rgb[k10, 1] + w01 * rgb[k01, 1] + w11 * rgb[k11, 1],
            w00 * rgb[k00, 2] + w10 * rgb[k10, 2] + w01 * rgb[k01, 2] + w11 * rgb[k11, 2])


@njit(**JIT)
def mesh_color(geo, hit, mat, bilinear):
    """Colour of triangle hit.prim at its hit: material colour times vertex
    colours times texture, where the mesh has them."""
    r, g, b = geo.mat_color[mat, 0], geo.mat_color[mat, 1], geo.mat_color[mat, 2]
    p, b1, b2 = hit.prim, hit.u, hit.v
    b0 = 1.0 - b1 - b2
    k0, k1, k2 = 0, 0, 0
    if geo.tri_vertex.shape[0] != 0:
        k0, k1, k2 = geo.tri_vertex[p, 0], geo.tri_vertex[p, 1], geo.tri_vertex[p, 2]
    if geo.vtx_color.shape[0] != 0:
        c = geo.vtx_color
        r *= b0 * c[k0, 0] + b1 * c[k1, 0] + b2 * c[k2, 0]
        g *= b0 * c[k0, 1] + b1 * c[k1, 1] + b2 * c[k2, 1]
        b *= b0 * c[k0, 2] + b1 * c[k1, 2] + b2 * c[k2, 2]
    if geo.mat_tex[mat, 1] != 0 and geo.vtx_uv.shape[0] != 0:
        uv = geo.vtx_uv
        s = b0 * uv[k0, 0] + b1 * uv[k1, 0] + b2 * uv[k2, 0]
        t = b0 * uv[k0, 1] + b1 * uv[k1, 1] + b2 * uv[k2, 1]
        tr, tg, tb = texture_rgb(geo, mat, s, t, bilinear)
        r *= tr
        g *= tg
        b *= tb
    return r, g, b
