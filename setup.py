"""The package list, found: every package under raytrace/ (so a new
structure's folder ships without a line anywhere), and assets/ as
raytrace.assets (pyproject.toml's package-dir).  Everything else is
configured in pyproject.toml."""
from setuptools import find_packages, setup


def packages():
    return find_packages(include=["raytrace", "raytrace.*"]) + ["raytrace.assets"]


if __name__ == "__main__":
    setup(packages=packages())
