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
