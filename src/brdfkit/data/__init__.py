"""Small data files shipped with brdfkit (see README.md here for sources and licences)."""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path


def default_envmap_path() -> Path:
    """The bundled CC0 environment map: Poly Haven's "Blouberg Sunrise 2", 256×128 Radiance HDR."""
    return Path(str(files(__name__) / "blouberg_sunrise_2_256x128.hdr"))


__all__ = ["default_envmap_path"]
