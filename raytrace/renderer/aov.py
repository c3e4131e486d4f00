"""Arbitrary output variables: per-pixel buffers saved beside the image.

The render driver fills them with ``aov=True``; all come from each
pixel's first camera sample.
"""
from pathlib import Path

# name -> what it holds (the README's table is this list)
AOVS = {
    "depth": "float32 (h, w): distance along the camera ray to the hit (inf: no hit)",
    "normal": "float32 (h, w, 3): unit shading normal at the hit (zeros: no hit)",
    "primid": "int64 (h, w): primitive id, triangles then spheres then planes (-1: no hit)",
    "cost": "int64 (h, w): box tests + primitive tests spent on the pixel, all samples",
}


def parse_aov_list(text):
    """"depth,normal" -> ["depth", "normal"]; raises ValueError naming the bad one."""
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise ValueError(f"expected a comma-separated list of {', '.join(AOVS)}")
    for n in names:
        if n not in AOVS:
            raise ValueError(f"unknown AOV {n!r} (choose from {', '.join(AOVS)})")
    return list(dict.fromkeys(names))


def aov_path(image_path):
    """teapot.png -> teapot.aov.npz, beside the image."""
    p = Path(image_path)
    stem = p.stem if p.suffix.lower() == ".png" else p.name
    return p.with_name(f"{stem}.aov.npz")
