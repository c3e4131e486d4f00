"""A mesh file's own materials (OBJ's MTL, glTF's PBR) as the renderer's
Material, and a warning for what it can only approximate.

The renderer has one colour (times a base-colour texture and vertex
colours), a white highlight (a scalar ``specular``), mirror and glass
weights (``reflect``, ``transmit``, ``ior``), emitted radiance
(``emission``, from MTL's Ke and glTF's emissiveFactor) and the path
tracer's glossy lobe (``glossy``, exponent ``shininess``): a material needing what it
lacks is approximated, and ``warn`` is told once per material and problem.
"""
from dataclasses import replace

import numpy as np

# MTL illum modes (the Wavefront MTL specification): those that ask for
# reflections traced from the surface, and those that ask for glass.
MIRROR_ILLUM = (3, 5, 8)
GLASS_ILLUM = (4, 6, 7, 9)
# Glass by its illum mode alone (no d or Tr): the share of light it lets
# through, and its index without Ni (window glass).
GLASS_TRANSMIT = 0.9
GLASS_IOR = 1.5
IOR_RANGE = (1.0, 10.0)

# glTF's Fresnel reflectance at normal incidence for a dielectric (the
# specification's 0.04).
DIELECTRIC_F0 = 0.04


def _clip01(values):
    return tuple(float(x) for x in np.clip(values, 0.0, 1.0))


def glossy_weight(reflectance, mat):
    """The path tracer's glossy weight for a specular reflectance at normal
    incidence (the normalised lobe reflects exactly its weight there), at
    most what ``mat``'s diffuse albedo leaves: diffuse x the colour's
    largest component + glossy <= 1, so no surface returns more light than
    it receives (MTL's Kd + Ks often exceeds 1).  Whitted never reads it."""
    room = 1.0 - mat.diffuse * max(mat.color)
    return float(np.clip(min(reflectance, room), 0.0, 1.0))


def mtl_material(entry, base, source, warn, image=None, has_uv=False):
    """The Material of an MtlMaterial: Kd is the colour, times map_Kd's
    ``image`` (as trimesh read it) where the mesh has texture coordinates;
    the mean of Ks the specular weight (the highlight is white, so a
    coloured Ks keeps its energy, not its hue); Ns the shininess (at least
    1); illum 0 or 1 (no highlight) gives specular 0.  The same mean is the
    path tracer's ``glossy`` weight (glossy_weight), with Ns its exponent,
    where Ks is a highlight: not under illum 0 or 1, nor under the mirror
    and glass modes, whose Ks is the traced reflection (their mirror or
    glass event draws it).  Everything else comes from ``base``."""
    v = entry.values
    mat = replace(base)
    if "kd" in v:
        mat.color = _clip01(v["kd"])
    if "ks" in v:
        mat.specular = float(np.clip(np.mean(v["ks"]), 0.0, 1.0))
    if "ns" in v:       # MTL's range is 0..1000; the lobe's exponent is at least 1 here
        mat.shininess = float(np.clip(v["ns"][0], 1.0, 1000.0))
    if "ke" in v:       # emitted radiance (the path tracer's lights)
        mat.emission = tuple(max(0.0, float(x)) for x in v["ke"])
    illum = int(v["illum"][0]) if "illum" in v else None
    if illum in (0, 1):
        mat.specular = 0.0
    elif "ks" in v and illum not in MIRROR_ILLUM + GLASS_ILLUM:
        # The mean, not the largest, of a coloured Ks: the lobe is white, so
        # the mean keeps the reflected energy where the largest would add
        # light to the weaker channels (gold's 1, 0.77, 0.34: 0.70, not 1).
        mat.glossy = glossy_weight(mat.specular, mat)
    what = f"{source}: material {entry.name!r}"
    opacity = float(np.clip(v["d"][0] if "d" in v else (1.0 - v["tr"][0] if "tr" in v else 1.0),
                            0.0, 1.0))
    # Mirrors (illum 3, 5, 8) reflect by Ks (the specification's reflection
    # colour, its mean here), 1 without it; glass (illum 4, 6, 7, 9)
    # refracts with index Ni.  A dissolve (d or Tr) without a glass mode is
    # see-through without bending: glass of index 1, said once.
    if illum in MIRROR_ILLUM:
        mat.reflect = float(np.clip(np.mean(v["ks"]), 0.0, 1.0)) if "ks" in v else 1.0
    if illum in GLASS_ILLUM or opacity < 1.0:
        mat.transmit = 1.0 - opacity if opacity < 1.0 else GLASS_TRANSMIT
        mat.reflect = min(mat.reflect, 1.0 - mat.transmit)
        mat.ior = float(np.clip(v["ni"][0], *IOR_RANGE)) if "ni" in v else GLASS_IOR
        if illum not in GLASS_ILLUM:
            mat.ior = 1.0
            key = f"d={v['d'][0]:g}" if "d" in v else f"Tr={v['tr'][0]:g}"
            warn(f"{what} is transparent ({key}); rendered as unbending glass letting "
                 f"{mat.transmit:.2g} through")
    if "map_kd" in v:
        mat.texture = _texture(image, has_uv, what, f"map_Kd {v['map_kd']}", "Kd", warn)
    for key in ("map_d", "refl"):
        if key in v:
            shown = {"map_d": "map_d", "refl": "refl"}[key]
            warn(f"{what} has an image texture ({shown} {v[key]}), which is not rendered")
    return mat


def _texture(image, has_uv, what, name, fallback, warn):
    """A material's base-colour image as linear RGB, or None with a warning
    saying why it is not used."""
    if image is None:
        warn(f"{what}: texture {name} could not be read; rendered with its {fallback} colour")
        return None
    if not has_uv:
        warn(f"{what} has a texture ({name}) but the mesh has no texture coordinates; "
             f"rendered with its {fallback} colour")
        return None
    try:
        rgb = np.asarray(image.convert("RGB"), dtype=np.float32) / np.float32(255.0)
    except (AttributeError, OSError, ValueError) as exc:
        warn(f"{what}: texture {name} could not be decoded ({exc}); rendered with its "
             f"{fallback} colour")
        return None
    return srgb_to_linear(rgb)


def srgb_to_linear(c):
    """The sRGB transfer function's inverse (IEC 61966-2-1), elementwise."""
    c = np.asarray(c)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(c.dtype)


def decode_colours(values, linear):
    """(n, 3) linear RGB of trimesh's colours ((n, 3 or 4), 8-bit or 0..1
    floats; alpha dropped), sRGB-decoded unless ``linear``."""
    a = np.asarray(values)
    if a.ndim != 2 or a.shape[1] < 3:
        return None
    rgb = a[:, :3].astype(np.float64)
    if np.issubdtype(a.dtype, np.integer):
        rgb /= 255.0
    rgb = np.clip(rgb, 0.0, 1.0)
    return rgb if linear else srgb_to_linear(rgb)


def gltf_material(pbr, base, source, warn, has_uv=False):
    """The Material of a trimesh PBRMaterial (glTF metallic-roughness).

    colour = baseColorFactor's RGB, times baseColorTexture where the mesh
    has texture coordinates.  Roughness r becomes the Blinn-Phong
    exponent 2 / r^4 - 2 (Walter et al. 2007's match of Beckmann and Phong
    lobes, with glTF's alpha = r^2), kept within 1..1000.  The highlight's
    reflectance F0 is 0.04 for a dielectric and the base colour's mean for a
    metal (mixed by metallic), scaled by (n + 8) / 8, Blinn-Phong's
    normalisation (Akenine-Moller et al., Real-Time Rendering), since the
    renderer's highlight is not normalised; at most 1.  A metal keeps half
    of ``base``'s diffuse weight: the renderer's highlight is white, so its
    colour can show only as diffuse light.  Under the path tracer F0 itself
    is the ``glossy`` weight (glossy_weight; the lobe is normalised), with
    the same exponent.  Absent factors take glTF's defaults (colour 1, 1,
    1, 1; metallic 1; roughness 1).  KHR_materials_specular is not read
    (trimesh drops it).
    """
    mat = replace(base)
    rgba = _base_color(getattr(pbr, "baseColorFactor", None))
    metallic = _factor(getattr(pbr, "metallicFactor", None))
    rough = _factor(getattr(pbr, "roughnessFactor", None))
    mat.color = _clip01(rgba[:3])
    mat.shininess = float(np.clip(2.0 / max(rough, 1e-3) ** 4 - 2.0, 1.0, 1000.0))
    f0 = DIELECTRIC_F0 * (1.0 - metallic) + float(np.mean(rgba[:3])) * metallic
    mat.specular = float(min(1.0, f0 * (mat.shininess + 8.0) / 8.0))
    mat.diffuse = base.diffuse * (1.0 - 0.5 * metallic)
    mat.glossy = glossy_weight(f0, mat)
    emissive = getattr(pbr, "emissiveFactor", None)
    if emissive is not None:    # glTF's emitted colour (its default: none)
        e = np.asarray(emissive, dtype=np.float64).ravel()
        if e.size >= 3 and np.isfinite(e[:3]).all():
            mat.emission = tuple(float(x) for x in np.maximum(e[:3], 0.0))
    name = getattr(pbr, "name", None)
    what = f"{source}: material {name!r}" if name else f"{source}: a material"
    alpha_mode = str(getattr(pbr, "alphaMode", None) or "OPAQUE").upper()
    if alpha_mode == "BLEND" and rgba[3] < 1.0:
        mat.transmit, mat.ior = 1.0 - rgba[3], 1.0
        warn(f"{what} is transparent (alpha={rgba[3]:.3g}); rendered as unbending glass letting "
             f"{mat.transmit:.2g} through")
    if metallic >= 0.5 and rough < 0.5:
        # A polished metal mirrors its surroundings, blurred by roughness;
        # the renderer's mirror is sharp, so weight it down as it roughens.
        mat.reflect = min(metallic * (1.0 - 2.0 * rough), 1.0 - mat.transmit)
        warn(f"{what} is a polished metal (metallic={metallic:g}, roughness={rough:g}); "
             f"rendered as a sharp mirror of weight {mat.reflect:.2g}")
    if getattr(pbr, "baseColorTexture", None) is not None:
        mat.texture = _texture(pbr.baseColorTexture, has_uv, what, "baseColorTexture", "base",
                               warn)
    return mat


def _base_color(factor):
    """glTF's baseColorFactor as RGBA in 0..1 (trimesh keeps it as 8-bit
    integers); white if absent or unreadable."""
    try:
        arr = np.asarray(factor if factor is not None else [1.0] * 4).ravel()
        rgba = arr.astype(np.float64) / (255.0 if np.issubdtype(arr.dtype, np.integer) else 1.0)
    except (TypeError, ValueError):
        return np.ones(4)
    if rgba.size < 3 or not np.isfinite(rgba).all():
        return np.ones(4)
    return np.clip(np.append(rgba[:3], rgba[3] if rgba.size > 3 else 1.0), 0.0, 1.0)


def _factor(value, default=1.0):
    try:
        x = float(value)
    except (TypeError, ValueError):
        return default
    return float(np.clip(x, 0.0, 1.0)) if np.isfinite(x) else default
