"""What a non-editable install ships: every subpackage and every asset."""
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def setuptools_config():
    tomllib = pytest.importorskip("tomllib" if sys.version_info >= (3, 11) else "tomli")
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]


def test_every_folder_of_code_ships(setuptools_config):
    """setup.py's package list is every folder of raytrace/ holding code (a
    folder without __init__.py would be left out of a wheel) and the
    assets; pyproject.toml lists none of them itself."""
    import runpy
    listed = runpy.run_path(str(ROOT / "setup.py"), run_name="setup")["packages"]()
    code = {".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "raytrace").rglob("*.py")
            if "__pycache__" not in p.parts}
    assert set(listed) == code | {"raytrace.assets"}
    assert "packages" not in setuptools_config
    assert setuptools_config["package-dir"]["raytrace.assets"] == "assets"


def test_every_asset_type_is_package_data(setuptools_config):
    """Every asset but the README's pictures; a texture an MTL names is one."""
    patterns = setuptools_config["package-data"]["raytrace.assets"]
    textures = {line.split(None, 1)[1].strip() for mtl in (ROOT / "assets").glob("*.mtl")
                for line in mtl.read_text().splitlines() if line.startswith("map_Kd")}
    assert textures
    for path in (ROOT / "assets").iterdir():
        if path.name != "__init__.py" and path.is_file() and (path.suffix != ".png"
                                                              or path.name in textures):
            assert any(path.match(p) for p in patterns), path.name
