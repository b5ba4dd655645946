"""Locating the files shipped under ``world/assets/`` (URDFs, meshes, textures)."""

from __future__ import annotations

from pathlib import Path

from .errors import UnknownNameError

ASSET_DIR = Path(__file__).resolve().parent / "assets"


def asset_path(name: str) -> Path:
    """Return the absolute path of the asset file ``name`` (e.g. ``"bebop2.urdf"``).

    Raises :class:`UnknownNameError` listing the shipped assets when it is missing.
    """
    path = ASSET_DIR / name
    if not path.is_file():
        known = [p.name for p in ASSET_DIR.iterdir() if p.is_file() and not p.name.startswith("_")]
        raise UnknownNameError("asset", name, known)
    return path
