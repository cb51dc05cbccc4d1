"""Build hook: copy the top-level ``models/`` and ``scenarios/`` into the wheel's ``foam_mj`` package.

The top-level folders are the source of truth (``foam_mj/data.py`` finds them in a source checkout);
a non-editable install finds the copies inside the package. Every file is copied, subfolders included
(an MJCF's meshes, textures or included fragments may sit in ``models/meshes/`` and the like), except
hidden files and Python byte code; the copy replaces any left in ``build/`` by an earlier build, so a file
removed from the source is not shipped.
"""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent
DATA = ("models", "scenarios")


def data_files(folder: Path) -> list[Path]:
    """Every file under ``folder``, recursively, relative to it: not hidden, not byte code."""
    return sorted(p.relative_to(folder) for p in folder.rglob("*")
                  if p.is_file() and not any(part.startswith(".") or part == "__pycache__" for part in p.relative_to(folder).parts)
                  and p.suffix not in (".pyc", ".pyo"))


class BuildPyWithData(build_py):
    def run(self):
        super().run()
        if self.editable_mode:
            return
        for folder in DATA:
            target = Path(self.build_lib) / "foam_mj" / folder
            shutil.rmtree(target, ignore_errors=True)
            for rel in data_files(ROOT / folder):
                (target / rel).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(ROOT / folder / rel, target / rel)


setup(cmdclass={"build_py": BuildPyWithData})
