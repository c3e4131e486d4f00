"""Wavefront MTL material libraries: the keys the renderer can use.

Our own small parser rather than trimesh's: trimesh rounds Kd to 8 bits,
keeps no line numbers (a bad value cannot be named) and drops d, Tr and
illum; trimesh still splits the OBJ's faces by ``usemtl`` and names each
part's material, which is how the two meet (scene/formats/mesh.py).
"""
from dataclasses import dataclass, field


@dataclass
class MtlMaterial:
    name: str
    line: int                                   # of its ``newmtl``
    values: dict = field(default_factory=dict)  # key (lower case) -> tuple of floats, or str


# Keys read, and how many numbers each takes (1 or 3: a colour may also be
# given as one grey value).  Others (Ka, Tf, map_Bump, ...) are skipped.
COLOR_KEYS = ("kd", "ks", "ke")
NUMBER_KEYS = ("ns", "d", "tr", "illum", "ni")
MAP_KEYS = ("map_kd", "map_d", "refl")          # image textures, by their file name


def parse_mtl(text, source, warn):
    """{name: MtlMaterial} of an MTL file's text; a value that is not
    numbers is skipped with ``warn("source: line N: Kd: ...")``."""
    materials = {}
    current = None
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        key, _, rest = line.partition(" ")
        rest = rest.strip()
        low = key.lower()
        if low == "newmtl":
            current = MtlMaterial(rest, number)
            materials[rest] = current
            continue
        if low not in COLOR_KEYS + NUMBER_KEYS + MAP_KEYS:
            continue
        if current is None:
            warn(f"{source}: line {number}: {key} before any newmtl; ignored")
            continue
        if low in MAP_KEYS:
            current.values[low] = rest.split()[-1] if rest else ""
            continue
        words = rest.split()
        # A colour may be "Kd r g b" or one grey value; "Kd spectral ..." and
        # "Kd xyz ..." forms are not read.
        want = (1, 3) if low in COLOR_KEYS else (1,)
        try:
            values = tuple(float(w) for w in words)
            if len(values) not in want:
                raise ValueError
            if not all(abs(x) < float("inf") for x in values):
                raise ValueError
        except ValueError:
            shape = "a number" if want == (1,) else "3 numbers (r g b)"
            warn(f"{source}: line {number}: {key}: expected {shape}, got {rest!r}; ignored")
            continue
        current.values[low] = values * 3 if low in COLOR_KEYS and len(values) == 1 else values
    return materials
