"""Where the shipped assets are: example scene files and the data built-in
scenes use.  Imports nothing of raytrace, so any layer may ask."""
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
