"""The shipped example scene files and their descriptions."""
from raytrace.scene.assets import assets_dir


def describe(path):
    """The ``description`` of a scene file, or "" if it cannot be read (a
    listing never fails on a broken file)."""
    from raytrace.errors import RaytraceError
    from raytrace.scene.formats.scenefile import parse_toml
    try:
        text = parse_toml(path).get("description", "")
    except RaytraceError:
        return ""
    return text if isinstance(text, str) else ""


def example_files():
    """[(path, description)] of the shipped example scene files, by name."""
    return [(p, describe(p)) for p in sorted(assets_dir().glob("*.toml"))]


def example_names():
    """{short name: path} of the example scene files a name can stand for
    (``raytrace whitted``); a built-in scene keeps its name."""
    from raytrace.scene.builtin import BUILTIN
    return {p.stem: p for p in sorted(assets_dir().glob("*.toml")) if p.stem not in BUILTIN}


def resolve(name):
    """An example's path for its short name, else ``name`` as given: a
    built-in name, or a path (an existing file wins over an example)."""
    from pathlib import Path
    if not isinstance(name, str) or "/" in name or "\\" in name or Path(name).suffix:
        return name
    path = example_names().get(name)
    return str(path) if path is not None and not Path(name).exists() else name
