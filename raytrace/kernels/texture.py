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
def _texel(geo, mat, i, j):
    """Texel in column i, row j counted from the bottom, both wrapped."""
    off, w, h = geo.mat_tex[mat, 0], geo.mat_tex[mat, 1], geo.mat_tex[mat, 2]
    i %= w   # Python's modulo: never negative
    j %= h
    k = off + (h - 1 - j) * w + i
    return geo.tex_rgb[k, 0], geo.tex_rgb[k, 1], geo.tex_rgb[k, 2]


@njit(**JIT)
def texture_rgb(geo, mat, s, t, bilinear):
    """Material ``mat``'s texture at (s, t): the nearest texel, or the
    bilinear blend of the four around it (texel centres at (i + 0.5) /
    width)."""
    w, h = geo.mat_tex[mat, 1], geo.mat_tex[mat, 2]
    # The fraction first, so a huge coordinate cannot overflow an integer.
    x = (s - np.floor(s)) * w
    y = (t - np.floor(t)) * h
    if not bilinear:
        return _texel(geo, mat, int(x), int(y))
    x -= 0.5
    y -= 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = x - x0, y - y0
    i, j = int(x0), int(y0)
    r00, g00, b00 = _texel(geo, mat, i, j)
    r10, g10, b10 = _texel(geo, mat, i + 1, j)
    r01, g01, b01 = _texel(geo, mat, i, j + 1)
    r11, g11, b11 = _texel(geo, mat, i + 1, j + 1)
    w00, w10, w01, w11 = (1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy
    return (w00 * r00 + w10 * r10 + w01 * r01 + w11 * r11,
            w00 * g00 + w10 * g10 + w01 * g01 + w11 * g11,
            w00 * b00 + w10 * b10 + w01 * b01 + w11 * b11)


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
