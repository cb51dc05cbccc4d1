"""The package as a user gets it: a non-editable wheel finds every scene; every MJCF compiles on its own."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import mujoco
import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("xml", sorted(p.name for p in (ROOT / "models").glob("*.xml")))
def test_every_mjcf_compiles_on_its_own_with_plain_mujoco(xml):
    m = mujoco.MjModel.from_xml_path(str(ROOT / "models" / xml))
    assert m.nbody >= 1  # at least the world (include fragments such as scene_common.xml hold only defaults)


@pytest.mark.slow
def test_a_non_editable_wheel_finds_every_scene(tmp_path):
    """`pip wheel` of a copy of the source, installed with `pip install --target`, run without the checkout."""
    src = tmp_path / "src"
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(".git", "build", "*.egg-info", "__pycache__", ".pytest_cache",
                                                                ".hypothesis", "out", "tests", "docs", "benchmarks"))
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    # No build isolation: the test extra brings setuptools>=77 (no network needed).
    build = subprocess.run([*pip, "wheel", "--no-deps", "--no-build-isolation", "-w", str(tmp_path / "dist"), str(src)],
                           capture_output=True, text=True, timeout=300)
    assert build.returncode == 0, build.stderr
    wheel = next((tmp_path / "dist").glob("foam_mj-*.whl"))
    site = tmp_path / "site"
    inst = subprocess.run([*pip, "install", "--no-deps", "--target", str(site), str(wheel)], capture_output=True, text=True, timeout=300)
    assert inst.returncode == 0, inst.stderr
    code = (
        "import foam_mj, foam_mj.data as d\n"
        "from foam_mj.scenarios import available_scenarios, load_scenario\n"
        f"assert foam_mj.__file__.startswith({str(site)!r}), foam_mj.__file__\n"
        "names = available_scenarios()\n"
        "for n in names:\n"
        "    s = load_scenario(n)\n"
        "    assert str(s.scene).startswith(str(d.models_dir())), s.scene\n"
        "print(len(names), d.models_dir())\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(site)
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
    assert run.returncode == 0, run.stderr
    count, folder = run.stdout.split()
    assert int(count) == len(list((ROOT / "scenarios").glob("*.toml"))) and folder.startswith(str(site))
    cli = subprocess.run([sys.executable, "-m", "foam_mj.cli", "scenes"], capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
    assert cli.returncode == 0 and "obstacle" in cli.stdout, cli.stderr
