"""Where the shipped MJCF models and scenario TOMLs live.

The top-level ``models/`` and ``scenarios/`` folders of the source tree are the source of truth.
A wheel carries copies of them inside the package (``foam_mj/models``, ``foam_mj/scenarios``, put
there by the build hook in ``setup.py``); a source checkout or an editable install reads the
top-level folders directly.
"""

from __future__ import annotations

from functools import cache
from importlib.resources import files
from pathlib import Path

_PACKAGE = Path(str(files("foam_mj")))


def _data_dir(name: str) -> Path:
    inside = _PACKAGE / name
    if inside.is_dir():
        return inside
    return _PACKAGE.parent / name


@cache
def models_dir() -> Path:
    """The folder of the shipped MJCF files (robots, and one scene file per scene)."""
    return _data_dir("models")


@cache
def scenarios_dir() -> Path:
    """The folder of the built-in scenario TOMLs."""
    return _data_dir("scenarios")


def model_path(name: str) -> Path:
    """The path of a shipped MJCF file, e.g. ``model_path("obstacle.xml")``."""
    return models_dir() / name
