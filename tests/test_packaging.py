"""The package as a user gets it: a non-editable wheel finds every scene and ships every file of models/ and
scenarios/; the sdist is the whole source; every MJCF compiles on its own."""

from __future__ import annotations

import os
import shutil
import struct
import subprocess
import sys
import tarfile
import zipfile
import zlib
from pathlib import Path

import mujoco
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("xml", sorted(p.name for p in (ROOT / "models").glob("*.xml")))
def test_every_mjcf_compiles_on_its_own_with_plain_mujoco(xml):
    m = mujoco.MjModel.from_xml_path(str(ROOT / "models" / xml))
    assert m.nbody >= 1  # at least the world (include fragments such as scene_common.xml hold only defaults)


def _png(path: Path) -> None:
    """A 2 x 2 grey PNG (a texture file MuJoCo reads), written with the standard library."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    raw = b"".join(b"\x00" + b"\x80\x80\x80" * 2 for _ in range(2))
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 2, 2, 8, 2, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def _add_probe_assets(src: Path) -> str:
    """A scene under models/ whose mesh and texture sit in subfolders (as a robot's meshes/ and textures/ do), and a
    scenario in a subfolder of scenarios/: files a build that copied only the top level, or only some suffixes, would
    leave out. Returns the probe scene's file name."""
    assets = src / "models" / "probe_assets"
    (assets / "textures").mkdir(parents=True)
    (assets / "tetra.obj").write_text("v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    _png(assets / "textures" / "grey.png")
    (src / "models" / "probe_scene.xml").write_text(
        '<mujoco><asset><mesh name="tetra" file="probe_assets/tetra.obj"/>'
        '<texture name="grey" type="2d" file="probe_assets/textures/grey.png"/><material name="m" texture="grey"/></asset>'
        '<worldbody><body><joint type="hinge"/><geom type="mesh" mesh="tetra" material="m"/></body></worldbody></mujoco>')
    (src / "scenarios" / "probe_extra").mkdir()
    (src / "scenarios" / "probe_extra" / "note.toml").write_text("# a file in a subfolder of scenarios/\n")
    return "probe_scene.xml"


def _data_files(src: Path) -> list[str]:
    return sorted(p.relative_to(src).as_posix() for folder in ("models", "scenarios") for p in (src / folder).rglob("*")
                  if p.is_file() and "__pycache__" not in p.parts)


@pytest.mark.slow
def test_a_non_editable_wheel_finds_every_scene(tmp_path):
    """`pip wheel` of a copy of the source, installed with `pip install --target`, run without the checkout: every file
    under models/ and scenarios/ is in the wheel, subfolders included (the build hook once copied only *.xml, *.stl and
    *.obj at the top level), and a scene whose mesh and texture sit in subfolders compiles from the installed copy."""
    src = tmp_path / "src"
    # Only what a wheel build reads: the checkout's own virtual environment (README: `python3 -m venv .venv` in it; CI
    # too), 1.5 GB with the test and cluster extras, was copied as well (25 s of this test instead of 7).
    junk = shutil.ignore_patterns("build", "*.egg-info", "__pycache__", ".pytest_cache", ".hypothesis")
    for name in ("foam_mj", "models", "scenarios"):
        shutil.copytree(ROOT / name, src / name, ignore=junk)
    for name in ("setup.py", "pyproject.toml", "MANIFEST.in", "README.md", "LICENSE"):
        shutil.copy2(ROOT / name, src / name)
    probe = _add_probe_assets(src)
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    # No build isolation: the test extra brings setuptools>=77 (no network needed).
    build = subprocess.run([*pip, "wheel", "--no-deps", "--no-build-isolation", "-w", str(tmp_path / "dist"), str(src)],
                           capture_output=True, text=True, timeout=300)
    assert build.returncode == 0, build.stderr
    wheel = next((tmp_path / "dist").glob("foam_mj-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    assert "foam_mj/py.typed" in names and any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    missing = [rel for rel in _data_files(src) if f"foam_mj/{rel}" not in names]
    assert missing == [], f"not in the wheel: {missing}"
    dist_info = "-".join(wheel.name.split("-")[:2]) + ".dist-info"
    assert [n for n in names if n.split("/")[0] not in ("foam_mj", dist_info)] == []  # no tests, docs or build junk
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
        "import mujoco\n"
        f"assert mujoco.MjModel.from_xml_path(str(d.model_path({probe!r}))).nmesh == 1\n"
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


def test_the_sdist_holds_the_whole_source_and_the_license(tmp_path):
    """Everything the test suite needs to run from an unpacked sdist (its conftest and helpers, the examples and
    benchmarks it runs, the docs the README links to), the package, its data and the license text."""
    src = tmp_path / "src"
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(".git", "build", "dist", "*.egg-info", "__pycache__", "*.pyc",
                                                                ".pytest_cache", ".hypothesis", ".venv", "out"))
    _add_probe_assets(src)  # a texture in a subfolder of models/ was left out by MANIFEST.in's suffix list
    code = "from setuptools import build_meta; print(build_meta.build_sdist(sys.argv[1]))"
    run = subprocess.run([sys.executable, "-c", f"import sys; {code}", str(tmp_path / "dist")], capture_output=True,
                         text=True, cwd=src, timeout=300)
    assert run.returncode == 0, run.stderr
    with tarfile.open(tmp_path / "dist" / run.stdout.split()[-1]) as sdist:
        names = {m.name.split("/", 1)[1] for m in sdist.getmembers() if m.isfile()}
    folders = ("foam_mj", "models", "scenarios", "tests", "examples", "benchmarks", "docs")
    expected = {p.relative_to(src).as_posix() for f in folders for p in (src / f).rglob("*") if p.is_file()}
    expected |= {"LICENSE", "README.md", "pyproject.toml", "setup.py", "MANIFEST.in"}
    assert sorted(expected - names) == []


def test_the_readmes_layout_names_every_module_and_model():
    """The README's Layout is where a reader looks for a module: every module of foam_mj/, foam_mj/planners/ and
    foam_mj/smoothing/ and every MJCF of models/ is named there (the optimal smoother's scp.py and the smoothers'
    base.py were not)."""
    import re

    readme = (ROOT / "README.md").read_text()
    layout = readme[readme.index("## Layout"):]
    named = set(re.findall(r"[a-z][a-z0-9_]*", layout))
    modules = [p for folder in ("foam_mj", "foam_mj/planners", "foam_mj/smoothing") for p in sorted((ROOT / folder).glob("*.py"))
               if not p.stem.startswith("__")]
    missing = [str(p.relative_to(ROOT)) for p in modules if p.stem not in named]
    missing += [f"models/{p.name}" for p in sorted((ROOT / "models").glob("*.xml"))
                if p.stem not in named and not re.fullmatch(r"(obstacle|step_up|step_down)5?|walker_(corridor|two_routes)", p.stem)]
    assert not missing, missing


def test_the_package_exports_the_first_names_a_user_needs_without_importing_mujoco():
    """``import foam_mj`` stays light (every command's start-up, ``--help`` included, goes through it); the names of
    the README's Python example are attributes of the package, the very objects their modules define."""
    code = (
        "import sys, foam_mj\n"
        "heavy = sorted(m for m in ('mujoco', 'scipy', 'clarabel', 'foam_mj.planners') if m in sys.modules)\n"
        "assert not heavy, heavy\n"
        "import foam_mj.planners, foam_mj.smoothing, foam_mj.scenarios, foam_mj.pipeline, foam_mj.errors\n"
        "assert foam_mj.get_planner is foam_mj.planners.get_planner\n"
        "assert foam_mj.get_smoother is foam_mj.smoothing.get_smoother\n"
        "assert foam_mj.load_scenario is foam_mj.scenarios.load_scenario\n"
        "assert foam_mj.run is foam_mj.pipeline.run\n"
        "assert foam_mj.PlanningFailed is foam_mj.errors.PlanningFailed\n"
        "assert set(foam_mj.__all__) <= set(dir(foam_mj))\n"
        "missing = [n for n in foam_mj.__all__ if not hasattr(foam_mj, n)]\n"
        "assert not missing, missing\n"
        "try:\n"
        "    foam_mj.no_such_name\n"
        "except AttributeError as exc:\n"
        "    assert 'no_such_name' in str(exc)\n"
        "else:\n"
        "    raise AssertionError('an unknown name must raise AttributeError')\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr


def test_the_packages_docstring_example_plans_and_smooths_a_certified_path():
    import foam_mj

    s = foam_mj.load_scenario("obstacle")
    oracle = s.oracle()
    problem = foam_mj.PlanningProblem(oracle, s.q_init, s.q_goal, delta=oracle.delta)
    result = foam_mj.get_planner("bubbletree").plan(problem, seed=0)
    path = foam_mj.get_smoother("optimal").smooth(result.rosary, seed=0)
    assert result.rosary.all_in_hatches(path.waypoints)
    P = path.path
    t = np.linspace(0.0, 1.0, 200)[:, None]
    dense = np.concatenate([a + t * (b - a) for a, b in zip(P[:-1], P[1:])])
    assert oracle.clearance.batch(dense).min() >= oracle.delta


def test_every_error_the_python_api_raises_is_importable_from_the_package_and_named_in_the_readme():
    """An application catches foam-mj's errors by class: each one the first names of the package raise for a user's mistake
    or a plan that cannot be made is a FoamError, the package's own attribute, and named in the README. get_planner's
    PlannerError and run()'s TimingInfeasible were neither (only foam_mj.planners.base and foam_mj.timing had them)."""
    import foam_mj
    from foam_mj.limits import Limits

    s = foam_mj.load_scenario("obstacle")
    oracle = s.oracle()
    cases = {
        "PlannerError": lambda: foam_mj.get_planner("no_such_planner"),
        "ScenarioError": lambda: foam_mj.load_scenario("no_such_scenario"),
        "ModelError": lambda: foam_mj.RobotModel.from_xml(Path("no_such_robot.xml")),
        "ConfigurationError": lambda: foam_mj.PlanningProblem(oracle, s.q_init[:2], s.q_goal, delta=oracle.delta),
        "PlanningFailed": lambda: foam_mj.get_planner("bubbletree").plan(
            foam_mj.PlanningProblem(oracle, s.q_init, s.q_goal, delta=oracle.delta, max_bubbles=3), seed=0),
        "TimingInfeasible": lambda: foam_mj.run(s, smoothers="convex", dynamic=False, limits=Limits(torque=(1e-3,) * 3)),
    }
    readme = (ROOT / "README.md").read_text()
    for name, call in cases.items():
        with pytest.raises(foam_mj.FoamError) as caught:
            call()
        assert type(caught.value).__name__ == name
        assert name in foam_mj.__all__ and getattr(foam_mj, name) is type(caught.value), name
        assert f"`{name}`" in readme, name


def test_no_library_code_is_switched_off_by_a_module_constant():
    """Dead code: a branch under ``if FLAG:`` where the module sets ``FLAG = False`` (or 0, None) never runs, yet is
    read, linted and kept in step (the corridor's ``DEBUG = False`` guarded a print of every refinement round)."""
    import ast

    dead = []
    for p in sorted((ROOT / "foam_mj").rglob("*.py")):
        tree = ast.parse(p.read_text(encoding="utf-8"))
        off = {t.id for node in tree.body if isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant)
               and not node.value.value for t in node.targets if isinstance(t, ast.Name)}
        dead += [f"{p.relative_to(ROOT)}:{node.lineno} if {node.test.id}" for node in ast.walk(tree)
                 if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id in off]
    assert not dead, dead


def test_every_configuration_argument_of_the_library_is_typed():
    """A configuration handed to the library (``q``, ``q_init``, ``q_goal``) is typed by every public function taking it:
    the oracle's radius and explain, the model's validate, plan and the planners took an untyped q (any sequence of
    numbers is validated, hence ``ArrayLike``)."""
    import ast

    untyped = []
    for p in sorted((ROOT / "foam_mj").rglob("*.py")):
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not (node.name.startswith("_") and not node.name.startswith("__")):
                a = node.args
                untyped += [f"{p.relative_to(ROOT)}:{node.lineno} {node.name}({arg.arg})"
                            for arg in a.posonlyargs + a.args + a.kwonlyargs
                            if arg.arg in ("q", "q_init", "q_goal") and arg.annotation is None]
    assert not untyped, untyped
