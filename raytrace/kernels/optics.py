"""Mirror and glass directions and the Fresnel weight (Whitted 1980; the
vector forms are pbrt-v4's Reflect and Refract, ch. 9.3 and 9.5).

Directions are unit vectors; ``n`` is a unit normal on the side the ray
arrives from (n . d < 0).
"""
import numpy as np
from numba import njit

from raytrace.kernels.jit import JIT


@njit(**JIT)
def reflect(dx, dy, dz, nx, ny, nz):
    """d mirrored about the plane with normal n."""
    k = 2.0 * (dx * nx + dy * ny + dz * nz)
    return dx - k * nx, dy - k * ny, dz - k * nz


@njit(**JIT)
def refract(dx, dy, dz, nx, ny, nz, eta):
    """(ok, tx, ty, tz): d bent through the surface by Snell's law, eta =
    n_incident / n_transmitted; ok False for total internal reflection."""
    cos_i = -(dx * nx + dy * ny + dz * nz)
    sin2_t = eta * eta * max(0.0, 1.0 - cos_i * cos_i)
    if sin2_t >= 1.0:
        return False, 0.0, 0.0, 0.0
    cos_t = np.sqrt(1.0 - sin2_t)
    k = eta * cos_i - cos_t
    return True, eta * dx + k * nx, eta * dy + k * ny, eta * dz + k * nz


@njit(**JIT)
def schlick(cos_i, eta):
    """Fresnel reflectance by Schlick's approximation (Schlick 1994), for a
    ray with cos_i = -d . n crossing from index ratio eta = n_i / n_t; 1
    past the critical angle.  Going into the denser side the cosine is the
    incident one; coming out of it, the transmitted one (the approximation
    is symmetric in that cosine)."""
    r0 = (1.0 - eta) / (1.0 + eta)
    r0 = r0 * r0
    c = cos_i
    if eta > 1.0:
        sin2_t = eta * eta * max(0.0, 1.0 - cos_i * cos_i)
        if sin2_t >= 1.0:
            return 1.0
        c = np.sqrt(1.0 - sin2_t)
    m = 1.0 - c
    return r0 + (1.0 - r0) * m * m * m * m * m


@njit(**JIT)
def bounce_weights(reflect_w, transmit_w, cos_i, eta):
    """(own, reflected, transmitted): the shares of a surface's light from
    its own shading, its mirror ray and its refracted ray, for material
    weights reflect_w + transmit_w <= 1.  Fresnel moves part of the
    transmitted share to the mirror ray, all of it past the critical angle;
    the three always sum to 1."""
    f = schlick(cos_i, eta) if transmit_w > 0.0 else 0.0
    return (1.0 - reflect_w - transmit_w, reflect_w + transmit_w * f,
            transmit_w - transmit_w * f)
