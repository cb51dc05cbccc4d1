"""Build hook: copy the top-level ``models/`` and ``scenarios/`` into the wheel's ``foam_mj`` package.

The top-level folders are the source of truth (``foam_mj/data.py`` finds them in a source checkout);
a non-editable install finds the copies inside the package.
"""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent
DATA = {"models": ("*.xml", "*.stl", "*.obj"), "scenarios": ("*.toml",)}


class BuildPyWithData(build_py):
    def run(self):
        super().run()
        if self.editable_mode:
            return
        for folder, patterns in DATA.items():
            target = Path(self.build_lib) / "foam_mj" / folder
            target.mkdir(parents=True, exist_ok=True)
            for pattern in patterns:
                for src in sorted((ROOT / folder).glob(pattern)):
                    shutil.copy2(src, target / src.name)


setup(cmdclass={"build_py": BuildPyWithData})
