"""The shipped assets: example scene files and the data built-in scenes use."""
from importlib import resources
from pathlib import Path

# A file only raytrace's own assets folder holds, so an unrelated top-level
# "assets" directory is never mistaken for it.
_MARKER = "teapot_patches.json"


def assets_dir():
    """The assets folder.

    In a source checkout (an editable install, or a worktree run with
    PYTHONPATH) that is ``assets/`` beside the package, so a checkout reads
    its own files and never those of whichever copy happens to be installed;
    otherwise the installed ``raytrace.assets`` package.
    """
    beside = Path(__file__).resolve().parents[2] / "assets"
    if (beside / _MARKER).is_file():
        return beside
    return Path(str(resources.files("raytrace.assets")))


def describe(path):
    """The ``description`` of a scene file, or "" if it cannot be read (a
    listing never fails on a broken file)."""
    from ..errors import RaytraceError
    from ..io.scenefile import parse_toml
    try:
        text = parse_toml(path).get("description", "")
    except RaytraceError:
        return ""
    return text if isinstance(text, str) else ""


def example_files():
    """[(path, description)] of the shipped example scene files, by name."""
    return [(p, describe(p)) for p in sorted(assets_dir().glob("*.toml"))]
