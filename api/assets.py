"""Locating the robot models shipped with the package (URDFs, meshes, tag layouts under ``world/assets/``).

These files are what a robot's designers wrote down: skills read them as
model facts (kinematics, dimensions, the tag bundle), the world loads them
into the simulator. The folder is found from the package's import spec, so
locating it never imports the simulator.
"""

from __future__ import annotations

from importlib.util import find_spec
from pathlib import Path

from .errors import UnknownNameError


def _asset_dir() -> Path:
    spec = find_spec("marsupial.world")
    if spec is None or not spec.submodule_search_locations:
        raise ImportError("marsupial.world is not installed: its robot models (world/assets) cannot be found")
    return Path(next(iter(spec.submodule_search_locations))).resolve() / "assets"


ASSET_DIR = _asset_dir()


def asset_path(name: str) -> Path:
    """Return the absolute path of the asset file ``name`` (e.g. ``"bebop2.urdf"``).

    Raises :class:`UnknownNameError` listing the shipped assets when it is missing.
    """
    path = ASSET_DIR / name
    if not path.is_file():
        known = [p.name for p in ASSET_DIR.iterdir() if p.is_file() and not p.name.startswith("_")]
        raise UnknownNameError("asset", name, known)
    return path
