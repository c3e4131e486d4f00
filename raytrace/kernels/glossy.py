"""The path tracer's glossy lobe: normalised Phong (Lafortune & Willems
1994, "Using the modified Phong reflectance model for physically based
rendering"), beside the Lambertian lobe, for a material's ``glossy``
weight g and its ``shininess`` exponent n:

    f(l) = albedo / pi + g (n + 2) / (2 pi) cos^n(alpha)

alpha between l and the mirror direction r of the view about the shading
normal.  At normal incidence the glossy term reflects exactly g (the
(n + 2) / (2 pi) normalisation); elsewhere less, as part of its lobe falls
below the surface (absorbed).  Directions are drawn from one lobe, chosen
with probability g / (g + the albedo's largest component) for the glossy
one: the glossy lobe's density is (n + 1) / (2 pi) cos^n(alpha) about r
(its exact sampling), and the density MIS weighs with is the mixture's
(pbrt's one-sample choice among lobes).  Imported by the path tracer only.
"""
import numpy as np
from numba import njit

from raytrace.kernels.jit import JIT

_INV_PI = 1.0 / np.pi
_INV_2PI = 0.5 / np.pi


@njit(**JIT)
def lobe_value(lobe, nx, ny, nz, lx, ly, lz):
    """(f x cos, RGB; the mixture's solid-angle density) towards unit l for
    lobe = (albedo RGB, g, n, mirror direction r, glossy probability)."""
    alb, g, n, r, pg = lobe
    ndl = nx * lx + ny * ly + nz * lz
    if ndl <= 0.0:
        return (0.0, 0.0, 0.0), 0.0
    c = r[0] * lx + r[1] * ly + r[2] * lz
    cn = c ** n if c > 0.0 else 0.0
    fg = g * (n + 2.0) * _INV_2PI * cn
    pdf = (1.0 - pg) * ndl * _INV_PI + pg * (n + 1.0) * _INV_2PI * cn
    return ((alb[0] * _INV_PI + fg) * ndl, (alb[1] * _INV_PI + fg) * ndl,
            (alb[2] * _INV_PI + fg) * ndl), pdf


@njit(**JIT)
def about(ax, ay, az, x, y, z):
    """(x, y, z) in an orthonormal basis whose third axis is unit a (Duff
    et al. 2017)."""
    sign = 1.0 if az >= 0.0 else -1.0
    a = -1.0 / (sign + az)
    b = ax * ay * a
    tx, ty, tz = 1.0 + sign * ax * ax * a, sign * b, -sign * ax
    bx, by, bz = b, sign + ay * ay * a, -ay
    return x * tx + y * bx + z * ax, x * ty + y * by + z * ay, x * tz + y * bz + z * az


@njit(**JIT)
def phong_direction(r, n, u1, u2):
    """A direction about unit r with density (n + 1) / (2 pi) cos^n(alpha):
    cos(alpha) = u1^(1 / (n + 1)) inverts its distribution."""
    c = u1 ** (1.0 / (n + 1.0))
    s = np.sqrt(max(0.0, 1.0 - c * c))
    phi = 2.0 * np.pi * u2
    return about(r[0], r[1], r[2], s * np.cos(phi), s * np.sin(phi), c)
