"""Mesh files (.obj, .ply, .stl, .off, .glb, .gltf) to (vertices, faces) arrays.

trimesh is imported here only, on first use, so built-in scenes, scene
files without meshes and ``--help`` never pay for it.  trimesh raises many
exception types on a damaged file (ValueError, IndexError, KeyError,
struct.error, ...) or returns an empty mesh for garbage; every one of
them becomes a RaytraceError naming the file.
"""
import os
import re
import stat
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from raytrace.errors import RaytraceError
from raytrace.kernels.limits import MAX_COORD
from raytrace.scene.formats.ply import check_counts, read_simple_ply
from raytrace.scene.model import Material

MESH_EXTENSIONS = (".obj", ".ply", ".stl", ".off", ".glb", ".gltf")



def bad_coordinate_rows(a):
    """The first problem of an (n, 3) float64 array of coordinates:
    ("nonfinite" or "too large", first such row, number of such rows), or
    None.  Whole-array checks come first and rows are found only to name a
    bad one: NumPy's reductions along an axis of length 3 are slow (the
    row-wise checks alone cost more than a BVH query of the same rays).
    """
    if not np.isfinite(a).all():
        rows = ~np.isfinite(a).all(axis=1)
        return "nonfinite", int(np.argmax(rows)), int(rows.sum())
    if a.size and not np.abs(a).max() <= MAX_COORD:
        rows = ~(np.abs(a) <= MAX_COORD).all(axis=1)
        return "too large", int(np.argmax(rows)), int(rows.sum())
    return None


def is_mesh_path(name):
    return Path(str(name)).suffix.lower() in MESH_EXTENSIONS


# How far looks_like_mesh reads: an OBJ's first vertex comes after its
# comments and mtllib lines; the other formats say what they are at once.
HEAD_BYTES = {".obj": 1 << 16}


def looks_like_mesh(path):
    """Whether a mesh file begins as its format does (PLY's "ply" line,
    GLB's "glTF", a glTF's JSON object, an OFF header, an ASCII STL's
    "solid" or a binary one's size, an OBJ vertex line), read from its first
    bytes; False for a file it cannot read.  Not a check: reading the file
    names any problem.  The command tells of a first run's compile before
    loading only for a file that passes, so garbage gets its error alone."""
    path = Path(path)
    ext = path.suffix.lower()
    try:
        st = path.stat()
        if not stat.S_ISREG(st.st_mode):
            return False
        with path.open("rb") as f:
            head = f.read(HEAD_BYTES.get(ext, 4096)).removeprefix(b"\xef\xbb\xbf")
    except OSError:
        return False
    if ext == ".ply":
        return head[:3] == b"ply" and head[3:4] in (b"\n", b"\r")
    if ext == ".stl":
        binary = st.st_size >= 84 and st.st_size == 84 + 50 * int.from_bytes(head[80:84], "little")
        return binary or head.lstrip()[:5].lower() == b"solid"
    if ext == ".obj":
        return re.search(rb"(?m)^[ \t]*v[ \t]", head) is not None
    return {".glb": head[:4] == b"glTF", ".gltf": head.lstrip()[:1] == b"{",
            ".off": b"OFF" in head}.get(ext, False)


# An OBJ face corner whose vertex index is 0: OBJ counts from 1 (negative
# counts back from the last vertex), so 0 is out of range -- the usual sign
# of an exporter writing 0-based indices.  trimesh does not reject it: it
# quietly builds a different, smaller mesh.
_OBJ_ZERO_INDEX = re.compile(rb"(?m)^[ \t]*f[ \t](?:[^\r\n]*[ \t])?[+-]?0+(?=[/ \t\r\n]|$)")


def check_obj_indices(path, data):
    """Raise for an OBJ face that uses vertex index 0."""
    for start in _zero_tokens(data):
        line_start = data.rfind(b"\n", 0, start) + 1
        m = _OBJ_ZERO_INDEX.match(data, line_start, data.find(b"\n", start) % (len(data) + 1))
        if m:
            line = data.count(b"\n", 0, m.start()) + 1
            raise RaytraceError(f"{path}: line {line}: face uses vertex index 0, out of range "
                                "(OBJ indices start at 1)")


def _zero_tokens(data, chunk=1 << 24):
    """Offsets of the tokens that are a zero integer ("0", "-0", "000")
    after a blank and before a blank, a slash or the end: the only places
    _OBJ_ZERO_INDEX can match, found with whole-array tests a chunk at a
    time (the regex alone read 114 MB at 7 MB/s; an exported file has few
    such tokens, in "v 0 0 0" lines if anywhere)."""
    arr = np.frombuffer(data, np.uint8)
    n = len(arr)
    zero_byte = ord("0")
    blank, sign, end = (np.zeros(256, bool) for _ in range(3))
    blank[list(b" \t")] = sign[list(b"+-")] = end[list(b"/ \t\r\n")] = True
    for lo in range(0, n, chunk):
        hi = min(n, lo + chunk)
        top = hi
        while top < n and arr[top] == zero_byte:    # a run of zeros ends in this window
            top += 1
        base = max(lo - 2, 0)
        w = arr[base:min(top + 1, n)]
        # Runs of zeros begun after a blank or a sign: the first byte of
        # the window is never one (a run there began in the last chunk).
        run_start = np.flatnonzero(w[1:] == zero_byte) + 1
        run_start = run_start[(blank | sign)[w[run_start - 1]]]
        run_start = run_start[(run_start + base >= lo) & (run_start + base < hi)]
        # Where each run ends: the next byte that is not a zero.
        after = run_start + 1
        more = np.flatnonzero(after < len(w))
        while len(more):
            more = more[w[after[more]] == zero_byte]
            after[more] += 1
            more = more[after[more] < len(w)]
        ok = np.ones(len(run_start), bool)
        inside = after < len(w)
        ok[inside] = end[w[after[inside]]]
        ok &= inside | (base + len(w) == n)
        signed = sign[w[run_start - 1]]
        token = run_start - signed
        ok &= token >= 1
        ok[ok] = blank[w[token[ok] - 1]]
        yield from (base + token[ok]).tolist()


# Bytes of memory a byte of input file may take while it is read (a text
# mesh parsed into arrays, a TOML file into Python objects): a file larger
# than available memory / this is refused before it is read.
MEMORY_PER_FILE_BYTE = 8


def available_memory():
    """Bytes of physical memory free now (8 GiB if the system will not say)."""
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return 8 << 30


def check_readable(path):
    """Raise the usual one-line errors for an input file that cannot be read:
    missing, a directory, not a regular file (a FIFO would block forever, a
    device never end), a name the system refuses, or too large to load."""
    path = Path(path)
    try:
        st = path.stat()
    except FileNotFoundError:
        raise RaytraceError(f"{path}: no such file") from None
    except OSError as exc:       # a name too long, a loop of links, no permission
        raise RaytraceError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if stat.S_ISDIR(st.st_mode):
        raise RaytraceError(f"{path}: is a directory, not a file")
    if not stat.S_ISREG(st.st_mode):
        raise RaytraceError(f"{path}: not a regular file (a FIFO, socket or device cannot be read)")
    limit = available_memory() // MEMORY_PER_FILE_BYTE
    if st.st_size > limit:
        raise RaytraceError(f"{path}: {st.st_size / 2**30:.1f} GiB is more than this machine's "
                            f"free memory can load (at most {limit / 2**30:.1f} GiB of file)")
    try:
        with path.open("rb"):
            pass
    except OSError as exc:
        raise RaytraceError(f"{path}: cannot read ({exc.strerror or exc})") from None


def check_mesh_arrays(name, vertices, faces):
    """Validate user or file data: (n, 3) finite coordinates, (m, 3) integer
    faces indexing them.  Returns (float64 vertices, int64 faces)."""
    kind = getattr(vertices, "dtype", None)
    if np.iscomplexobj(vertices) or (kind is not None and kind.kind in "mM"):
        raise RaytraceError(f"{name}: vertices must be real numbers, got {vertices.dtype}")
    try:
        v = np.asarray(vertices, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise RaytraceError(f"{name}: vertices are not numbers ({exc})") from None
    try:
        np.asarray(faces)
    except ValueError as exc:   # ragged: rows of different lengths
        raise RaytraceError(f"{name}: faces must be an (m, 3) array of indices ({exc})") from None
    if v.ndim != 2 or v.shape[1] != 3:
        raise RaytraceError(f"{name}: vertices must have shape (n, 3), got {v.shape}")
    bad = bad_coordinate_rows(v)
    if bad is not None and bad[0] == "nonfinite":
        raise RaytraceError(f"{name}: vertex {bad[1]} has a NaN or infinite "
                            f"coordinate ({bad[2]} such vertices)")
    if bad is not None:
        k = bad[1]
        raise RaytraceError(f"{name}: vertex {k} has a coordinate of {np.abs(v[k]).max():.3g}, beyond "
                            f"the {MAX_COORD:g} the intersection tests can multiply without "
                            f"overflow ({bad[2]} such vertices)")
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3:
        raise RaytraceError(f"{name}: faces must have shape (m, 3), got {f.shape}")
    if f.size and not np.issubdtype(f.dtype, np.integer):
        raise RaytraceError(f"{name}: face indices must be integers, got {f.dtype}")
    f = f.astype(np.int64, copy=False)
    if f.size and (f.min() < 0 or f.max() >= len(v)):
        k = int(np.argmax(((f < 0) | (f >= len(v))).any(axis=1)))
        raise RaytraceError(f"{name}: face {k} indexes a vertex out of range "
                            f"({f[k].tolist()}, but there are {len(v)} vertices)")
    return v, f


@dataclass
class MeshPart:
    """One material's faces of a mesh file, placed where the file puts them."""
    vertices: np.ndarray             # (n, 3) float64
    faces: np.ndarray                # (m, 3) int64
    normals: np.ndarray = None       # (n, 3) the file's vertex normals, or None if it has none
    material: object = None          # the file's Material for these faces, or None
    colors: np.ndarray = None        # (n, 3) linear RGB per vertex, or None
    face_colors: np.ndarray = None   # (m, 3) linear RGB per face, or None
    uv: np.ndarray = None            # (n, 2) texture coordinates, or None
    welded: bool = False             # no two vertices at one position, bit for bit (an STL's)

    # Every array with a row per vertex: a split, weld or reorder of the
    # vertices applies to each of them (part_mesh).  A new one is added here.
    PER_VERTEX = ("vertices", "colors", "uv")


def read_mesh(path):
    """(vertices (n, 3) float64, faces (m, 3) int64) of a mesh file; a file
    holding several meshes (a glTF scene) gives them all, transformed."""
    parts = read_mesh_parts(path)
    offsets = np.cumsum([0] + [len(p.vertices) for p in parts[:-1]])
    return (np.concatenate([p.vertices for p in parts]),
            np.concatenate([p.faces + k for p, k in zip(parts, offsets)]))


def read_mesh_parts(path, warn=None, base=None):
    """The MeshParts of a mesh file: one per mesh and material (an OBJ's
    ``usemtl`` groups, a glTF scene's meshes), with the file's own vertex
    normals and materials (made from ``base``, scene/formats/materials.py).  What the
    renderer cannot show (transparency, textures, vertex colours) and a
    missing or damaged MTL file are told to ``warn`` as one line each; the
    mesh still loads."""
    path = Path(path)
    warn = warn or (lambda message: None)
    ext = path.suffix.lower()
    if ext not in MESH_EXTENSIONS:
        raise RaytraceError(f"{path}: not a mesh file (expected one of {', '.join(MESH_EXTENSIONS)})")
    check_readable(path)
    if path.stat().st_size == 0:
        raise RaytraceError(f"{path}: file is empty")
    try:
        simple = (read_simple_ply(path) if ext == ".ply"
                  else _stl(path) if ext == ".stl"
                  else _fast_obj(path, warn) if ext == ".obj" else None)
    except MemoryError:
        raise RaytraceError(f"{path}: out of memory reading the mesh") from None
    if simple is not None:
        parts = [MeshPart(**simple)]
    else:
        library = data = None
        if ext == ".obj":
            data = path.read_bytes()
            check_obj_indices(path, data)
            library = _obj_materials(path, data, warn)
            # A byte-order mark (some Windows editors) would hide the first line.
            data = data[3:] if data.startswith(b"\xef\xbb\xbf") else None
        elif ext == ".ply":
            check_counts(path)
        parts = _read_with_trimesh(path, ext, library, warn, base, data)
        if ext == ".stl":      # an ASCII STL's triangle soup (several solids, capitals)
            from raytrace.scene.formats.stl import weld
            for p in parts:
                if p is not None:
                    p.vertices, p.faces = weld(np.asarray(p.vertices, np.float64),
                                               np.asarray(p.faces, np.int64))
                    p.normals, p.welded = None, True
    parts = [p for p in parts if p is not None and len(p.faces)]
    if not parts:
        raise RaytraceError(f"{path}: no non-degenerate triangles (no faces found: damaged, or "
                            f"not really {ext[1:].upper()}?)")
    for p in parts:
        p.vertices, p.faces = check_mesh_arrays(path, p.vertices, p.faces)
        if p.normals is not None and np.shape(p.normals) != p.vertices.shape:
            p.normals = None
        _check_surface_arrays(path, p, warn)
    return parts


def _fast_obj(path, warn):
    from raytrace.scene.formats.obj import read_obj
    return read_obj(path, warn)


def _stl(path):
    from raytrace.scene.formats.stl import read_ascii_stl, read_binary_stl
    read = read_binary_stl(path)
    read = read_ascii_stl(path) if read is None else read
    return None if read is None else dict(vertices=read[0], faces=read[1], welded=True)


def _read_with_trimesh(path, ext, library, warn, base, data=None):
    """The MeshParts of any mesh file trimesh reads (None for a part that
    is not a triangle mesh); ``data``, if given, is read in place of the file."""
    try:
        import trimesh
        # process=False: keep the file's vertices and faces as they are
        # (no merging, no dropping), so errors in them are reported.
        if data is None:
            scene = trimesh.load_scene(str(path), file_type=ext[1:], process=False)
        else:
            import io
            scene = trimesh.load_scene(io.BytesIO(data), file_type=ext[1:], process=False,
                                       resolver=trimesh.resolvers.FilePathResolver(str(path)))
        for geometry in scene.geometry.values():
            shape = np.shape(getattr(geometry, "vertices", np.zeros((0, 3))))
            if len(shape) != 2 or shape[1] != 3:   # an OBJ line cut short: "v 0 1"
                raise ValueError(f"vertices of {shape[-1]} coordinates, not 3")
        parts = [_part(trimesh, scene, node, library, path.name, warn, base)
                 for node in scene.graph.nodes_geometry]
    except RaytraceError:
        raise
    except MemoryError:
        raise RaytraceError(f"{path}: out of memory reading the mesh") from None
    except Exception as exc:  # noqa: BLE001 -- trimesh's errors have no common base
        raise RaytraceError(f"{path}: not a readable {ext[1:].upper()} mesh ({_brief(exc)})") from None
    return parts


def _check_surface_arrays(path, part, warn):
    """Drop, with a warning, colours or texture coordinates that do not fit
    the mesh (a row count that differs, NaN); the mesh still renders."""
    for attr, rows, cols in (("colors", len(part.vertices), 3), ("uv", len(part.vertices), 2),
                             ("face_colors", len(part.faces), 3)):
        a = getattr(part, attr)
        if a is None:
            continue
        if np.shape(a) != (rows, cols) or not np.isfinite(a).all():
            what = "texture coordinates" if attr == "uv" else "colours"
            warn(f"{path.name}: the mesh's {what} are damaged (shape {np.shape(a)} for {rows} "
                 f"rows, or not finite); ignored")
            setattr(part, attr, None)
            if attr == "uv" and part.material is not None:
                part.material.texture = None


def part_mesh(part, base, crease, flat, name):
    """A scene Mesh of a MeshPart: its file's material (else ``base``) and
    shading normals.  Every per-vertex array (MeshPart.PER_VERTEX) follows
    the vertices through the crease split and the face-colour split."""
    from raytrace.scene.model import Mesh
    from raytrace.scene.normals import shading_split
    arrays = {k: getattr(part, k) for k in MeshPart.PER_VERTEX if getattr(part, k) is not None}
    # Vertices that carry more than a position stay apart where they meet.
    keep = len(arrays) > 1
    source, faces, normals = shading_split(part.vertices, part.faces, part.normals,
                                           crease=crease, flat=bool(flat), keep=keep,
                                           welded=part.welded)
    if part.face_colors is not None:
        # A colour per face: each face gets vertices of its own, after the
        # shading normals were found from the shared ones.
        corners = faces.reshape(-1)
        source = corners if source is None else source[corners]
        normals = normals[corners] if normals is not None else None
        faces = np.arange(len(corners), dtype=np.int64).reshape(-1, 3)
        arrays.pop("colors", None)
    if source is not None:
        arrays = {k: a[source] for k, a in arrays.items()}
    if part.face_colors is not None:
        arrays["colors"] = np.repeat(part.face_colors, 3, axis=0)
    return Mesh(arrays["vertices"], faces, part.material or base, normals=normals, name=name,
                colors=arrays.get("colors"), uv=arrays.get("uv"))


def _part(trimesh, scene, node, library, source, warn, base):
    """The MeshPart of one instance in a trimesh Scene (None if not a
    triangle mesh), moved by its transform as trimesh's Scene.dump does."""
    transform, name = scene.graph[node]
    mesh = scene.geometry[name]
    if not isinstance(mesh, trimesh.Trimesh):
        return None
    # trimesh computes vertex normals when asked for ones the file lacks;
    # normals read from the file are already in its cache (a private
    # attribute: tests/test_mesh_io.py checks both cases on every format).
    had_normals = "vertex_normals" in mesh._cache
    if np.array_equal(transform, np.eye(4)):
        # In place (a PLY, an OBJ, most STLs): no copies, no trimesh hashing,
        # both costly on big meshes.
        vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces)
        normals = np.asarray(mesh.vertex_normals) if had_normals else None
    else:
        moved = placed(trimesh, mesh, transform, mesh.vertex_normals if had_normals else None)
        vertices, faces = np.asarray(moved.vertices), np.asarray(moved.faces)
        normals = np.array(moved.vertex_normals) if had_normals else None
    part = MeshPart(vertices, faces, normals,
                    _visual_material(mesh.visual, library, source, warn, base))
    _visual_colours(part, mesh.visual, source.lower().endswith((".glb", ".gltf")))
    return part


def placed(trimesh, mesh, transform, normals=None):
    """A bare copy of a trimesh mesh moved by a 4x4 ``transform`` as
    trimesh's Scene.dump moves it: its vertex ``normals`` (if given) turned
    too, and mirrored faces flipped.  Bare: copying the visual too turns
    face colours into vertex colours, which needs scipy (a face-coloured
    PLY failed to load)."""
    moved = trimesh.Trimesh(np.array(mesh.vertices), np.array(mesh.faces), process=False)
    if normals is not None:
        moved.vertex_normals = normals
    moved.apply_transform(transform)
    return moved


def _visual_colours(part, visual, linear):
    """The part's vertex or face colours and texture coordinates from
    trimesh's visual.  8-bit colours are sRGB-encoded, but glTF's COLOR_0
    is linear (its specification), and trimesh keeps it so."""
    from raytrace.scene.formats.materials import decode_colours
    kind = getattr(visual, "kind", None)
    if kind == "vertex" and not hasattr(visual, "material"):
        part.colors = decode_colours(visual.vertex_colors, linear)
    elif kind == "face" and not hasattr(visual, "material"):
        part.face_colors = decode_colours(visual.face_colors, linear)
    attributes = getattr(visual, "vertex_attributes", None) or {}
    if attributes.get("color") is not None and part.colors is None:
        part.colors = decode_colours(attributes["color"], linear)
    # A texture was kept (scene/formats/materials.py) only where the visual has texture coordinates.
    if part.material is not None and part.material.texture is not None:
        part.uv = np.asarray(visual.uv, dtype=np.float64)


def _visual_material(visual, library, source, warn, base):
    """The Material trimesh's visual names (an MTL entry, a glTF PBR
    material) with its base-colour texture, or None for the default."""
    from raytrace.scene.formats.materials import gltf_material, mtl_material
    base = base or Material()
    material = getattr(visual, "material", None)
    if material is None:
        return None
    if type(material).__name__ == "PBRMaterial":
        return gltf_material(material, base, source, warn, has_uv=getattr(visual, "uv", None) is not None)
    entry = (library or {}).get(getattr(material, "name", None))
    if entry is None:
        return None
    return mtl_material(entry, base, source, warn, image=getattr(material, "image", None),
                        has_uv=getattr(visual, "uv", None) is not None)


_MTLLIB = re.compile(rb"(?m)^[ \t]*mtllib[ \t]+([^\r\n]*?)[ \t]*$")
_USEMTL = re.compile(rb"(?m)^[ \t]*usemtl[ \t]+([^\r\n]*?)[ \t]*$")


def _obj_materials(path, data, warn):
    """{name: MtlMaterial} of an OBJ's first ``mtllib`` (the one trimesh
    reads), or None; a missing or unreadable library is a warning."""
    from raytrace.scene.formats.mtl import parse_mtl
    # bytes.find before the regex: it reads 114 MB in a tenth of the time.
    m = _MTLLIB.search(data) if b"mtllib" in data else None
    if m is None:
        return None
    name = m.group(1).decode("utf-8", "replace")
    mtl = path.parent / name
    fallback = "rendered with the default material"
    try:
        check_readable(mtl)
        raw = mtl.read_bytes()
    except (RaytraceError, OSError) as exc:
        warn(f"{path.name}: material library {exc}; {fallback}")
        return None
    if b"\0" in raw:
        warn(f"{path.name}: material library {mtl}: not a text file; {fallback}")
        return None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    library = parse_mtl(text, mtl.name, warn)
    _check_texture_files(mtl, library)
    used = dict.fromkeys(u.decode("utf-8", "replace")
                         for u in (_USEMTL.findall(data) if b"usemtl" in data else ()))
    for u in used:
        if u not in library:
            warn(f"{path.name}: material {u!r} is not in {mtl.name}; {fallback}")
    return library


def _check_texture_files(mtl, library):
    """Refuse a texture that is there but not a regular file before trimesh
    opens it: reading a FIFO would wait forever, a device never end.  (A
    missing one trimesh reports, and the render goes on without it.)"""
    from raytrace.scene.formats.mtl import MAP_KEYS
    for entry in library.values():
        for key in MAP_KEYS:
            value = entry.values.get(key)
            if not isinstance(value, str) or not value.strip():
                continue
            for name in dict.fromkeys((value.strip(), value.split()[-1])):  # options come first
                candidate = mtl.parent / name
                try:
                    st = candidate.stat()
                except (OSError, ValueError):
                    continue
                if not stat.S_ISREG(st.st_mode) and not stat.S_ISDIR(st.st_mode):
                    raise RaytraceError(f"{mtl}: material {entry.name!r}: {key} {name}: not a regular "
                                        "file (a FIFO, socket or device cannot be read)")


def _brief(exc, limit=100):
    """The first line of an exception's message, cut to ``limit`` characters."""
    text = str(exc).strip()
    text = text.splitlines()[0] if text else type(exc).__name__
    return text if len(text) <= limit else text[:limit - 3] + "..."
