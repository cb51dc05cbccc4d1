"""Tests for foam_mj.figures: every figure from a real planned result (Agg, no window), the strobe's
geometry against MuJoCo's own geom poses, graceful degradation, the CLI entry point, the walker's
top-down map, and the message when matplotlib is missing."""

from __future__ import annotations

import copy
import json
import shutil
import sys
import xml.etree.ElementTree as ET
from foam_mj.data import scenarios_dir
from pathlib import Path

import mujoco
import numpy as np
import pytest

pytest.importorskip("matplotlib")

from foam_mj import cli, figures  # noqa: E402
from foam_mj.errors import FoamError  # noqa: E402
from foam_mj.figures import MISSING_MATPLOTLIB, robot_kind, strobe_geometry, write_figures  # noqa: E402
from foam_mj.model import RobotModel  # noqa: E402

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
SCENARIOS = scenarios_dir()


# -- helpers -------------------------------------------------------------------------------------------------
def check_png(path: Path, min_px: int = 300, max_px: int = 6000) -> tuple[int, int]:
    """A real, non-blank PNG of sensible size: signature, IHDR size, pixel variance."""
    from matplotlib.image import imread

    raw = path.read_bytes()
    assert raw[:8] == PNG_SIGNATURE, f"{path.name}: not a PNG"
    assert raw[12:16] == b"IHDR"
    width, height = int.from_bytes(raw[16:20], "big"), int.from_bytes(raw[20:24], "big")
    assert min_px <= width <= max_px and min_px <= height <= max_px, f"{path.name}: {width} x {height} px"
    img = imread(path)
    assert img.shape[:2] == (height, width)
    grey = img[..., :3].mean(axis=2)
    assert grey.var() > 1e-3, f"{path.name} is blank"
    assert (grey < 0.9).mean() > 0.01, f"{path.name} is almost all white"
    # Nothing is cut off: the layout leaves a blank margin all round.
    border = np.concatenate([grey[:2].ravel(), grey[-2:].ravel(), grey[:, :2].ravel(), grey[:, -2:].ravel()])
    assert border.min() > 0.9, f"{path.name}: something touches the image's edge (clipped text or legend?)"
    return width, height


def smooth_trajectory(waypoints: np.ndarray, robot: RobotModel, duration: float) -> tuple[np.ndarray, np.ndarray]:
    """Times and qpos rows at the model's timestep along the polyline, rest to rest (minimum jerk)."""
    dt = float(robot.model.opt.timestep)
    times = np.arange(int(round(duration / dt)) + 1) * dt
    tau = times / times[-1]
    s = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(waypoints, axis=0), axis=1))])
    q = np.column_stack([np.interp(s * arc[-1], arc, waypoints[:, i]) for i in range(waypoints.shape[1])])
    return times, robot.config.to_qpos(q)


def plan_json(tmp: Path, scene: str) -> dict:
    out = tmp / f"{scene}.json"
    code = cli.main(["plan", "--scene", scene, "--json", str(out), "--smoother", "none", "--no-replay", "--no-rrd"])
    assert code == 0, f"foam-mj plan --scene {scene} failed with exit code {code}"
    return json.loads(out.read_text())


# -- fixtures ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def planned(tmp_path_factory) -> dict:
    """A real result of `foam-mj plan --scene obstacle --json` (the centre path only, no times)."""
    return plan_json(tmp_path_factory.mktemp("plan"), "obstacle")


@pytest.fixture(scope="module")
def robot(planned) -> RobotModel:
    return RobotModel.from_xml(planned["mjcf"])


@pytest.fixture(scope="module")
def rich(planned, robot) -> dict:
    """The planned result plus what the smoothers and trajectories add: a timed "gradient" path, an
    "hs" path with a convergence history, and an "adjusted" path in a rosary of its own."""
    doc = copy.deepcopy(planned)
    centre = doc["paths"]["centre"]
    w = np.asarray(centre["waypoints"])
    ros = centre.get("rosary", doc["rosary"])
    # A shortcut through every other waypoint stands in for a smoothed path (only its drawing matters).
    short = np.vstack([w[:-1:2], w[-1:]])
    times, qpos = smooth_trajectory(short, robot, 1.2)
    doc["paths"]["gradient"] = {"waypoints": short.tolist(), "qpos": qpos.tolist(), "times": times.tolist(), "rosary": ros,
                                "smoother": {"objective": "SV"}, "convergence": {"best": [0.8, 0.5, 0.1], "mean": [0.8, 0.5, 0.1]}}
    it = np.arange(300)
    best = 3.3 + 1.7 * np.exp(-it / 60)
    hs_w = w + 0.01 * np.sin(np.arange(len(w)))[:, None]
    hs_w[[0, -1]] = w[[0, -1]]
    t_hs, q_hs = smooth_trajectory(hs_w, robot, 1.6)
    doc["paths"]["hs"] = {"waypoints": hs_w.tolist(), "qpos": q_hs.tolist(), "times": t_hs.tolist(), "rosary": ros,
                          "smoother": {"objective": "f"}, "convergence": {"best": best.tolist(), "mean": (best + 0.3 * np.exp(-it / 90)).tolist()}}
    adj = {"centers": (np.asarray(ros["centers"]) * 0.98 + 0.01).tolist(), "radii": ros["radii"], "bubble_ids": None}
    doc["paths"]["adjusted"] = {"waypoints": w.tolist(), "qpos": robot.config.to_qpos(w).tolist(), "rosary": adj}
    return doc


# -- every figure ----------------------------------------------------------------------------------------------
def test_every_figure_of_the_obstacle_scene(rich, tmp_path):
    had_pyplot = "matplotlib.pyplot" in sys.modules
    written = write_figures(rich, tmp_path, dpi=100)
    names = [p.name for p in written]
    assert names == ["foam.png", "rosary.png", "rosary_adjusted.png", "paths.png", "strobe.png", "convergence.png", "joints.png"]
    assert all(p.parent == tmp_path and p.is_file() for p in written)
    sizes = {p.stem: check_png(p) for p in written}
    w, h = sizes["strobe"]
    assert w > h  # four panels side by side
    # Only the object-oriented API: pyplot (and with it a GUI backend) is never imported.
    assert had_pyplot or "matplotlib.pyplot" not in sys.modules


def test_svg_and_pdf_on_request(rich, tmp_path):
    doc = dict(rich, foam=None)  # the foam's vector output is slow to write; the CLI test writes foam.svg
    written = write_figures(doc, tmp_path, formats=("svg", "pdf"), paths=["centre"], dpi=80)
    assert sorted(p.name for p in written) == sorted(f"{s}.{f}" for s in ("rosary", "strobe") for f in ("svg", "pdf"))
    for p in written:
        raw = p.read_bytes()
        assert len(raw) > 5000, p.name
        if p.suffix == ".pdf":
            assert raw.startswith(b"%PDF-") and raw.rstrip().endswith(b"%%EOF")
        else:
            root = ET.fromstring(raw)
            assert root.tag.endswith("svg")


def test_optional_parts_are_skipped(planned, tmp_path):
    # The plain planned result: one untimed path without convergence -> no joints, no convergence figure.
    names = [p.name for p in write_figures(planned, tmp_path / "plain", dpi=60)]
    assert names == ["foam.png", "rosary.png", "strobe.png"]
    # No foam and no rosary (a bare path): the paths and the strobe only.
    bare = copy.deepcopy(planned)
    bare["foam"] = None
    bare["rosary"] = None
    for entry in bare["paths"].values():
        entry.pop("rosary", None)
    names = [p.name for p in write_figures(bare, tmp_path / "bare", dpi=60)]
    assert names == ["paths.png", "strobe.png"]
    for p in (tmp_path / "bare").iterdir():
        check_png(p, min_px=150)


def test_bad_requests_are_foam_errors(planned, tmp_path):
    with pytest.raises(FoamError, match="unknown figure format"):
        write_figures(planned, tmp_path, formats=("bmp",))
    with pytest.raises(FoamError, match="no path named"):
        write_figures(planned, tmp_path / "unmade", paths=["nope"])
    assert not (tmp_path / "unmade").exists()   # refused before the folder is created
    (tmp_path / "file").write_text("x")
    with pytest.raises(FoamError, match="is a file"):
        write_figures(planned, tmp_path / "file")
    bad = copy.deepcopy(planned)
    bad["paths"]["centre"]["times"] = [0.0, 1.0]
    with pytest.raises(FoamError, match="times for"):
        write_figures(bad, tmp_path / "bad")
    for dpi in (float("nan"), float("inf"), 1.5, True, 0, 601, None):  # were matplotlib's ValueError, OverflowError,
        with pytest.raises(FoamError, match=r"`dpi` \(--dpi\) must be an integer in \[10, 600\]"):  # FreeType's error
            write_figures(planned, tmp_path / "dpi", dpi=dpi)
    assert not (tmp_path / "dpi").exists()
    with pytest.raises(FoamError, match=r"no path named \['nope'\]"):  # one name, not ['n', 'o', 'p', 'e']
        write_figures(planned, tmp_path / "unmade", paths="nope")
    bad = copy.deepcopy(planned)
    bad["mjcf"] = 5  # was RobotModel.from_xml's TypeError: an internal error, exit 1, from `foam-mj figures`
    with pytest.raises(FoamError, match=r"field 'mjcf' must be the path of the MJCF scene \(a string\), got 5"):
        write_figures(bad, tmp_path / "bad")


# -- the strobe's geometry is MuJoCo's ----------------------------------------------------------------------
def mujoco_box_corners_xz(m: mujoco.MjModel, qpos: np.ndarray, geom: str) -> np.ndarray:
    """The box's eight corners from a fresh MjData, projected onto x-z (four distinct points)."""
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    g = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, geom)
    R = d.geom_xmat[g].reshape(3, 3)
    size = m.geom_size[g]
    corners = [d.geom_xpos[g] + R @ (np.array([sx, sy, sz]) * size) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    return np.unique(np.round(np.array(corners)[:, [0, 2]], 12), axis=0)


def sort_rows(a: np.ndarray) -> np.ndarray:
    return a[np.lexsort(a.T[::-1])]


@pytest.mark.parametrize("which", ["q_init", "q_goal"])
def test_strobe_draws_the_foot_where_mujoco_puts_it(planned, robot, which):
    q = np.asarray(planned[which])
    shapes = {s.name: s for s in strobe_geometry(robot, q)}
    assert {"thigh_collision", "shank_collision", "foot_collision", "obstacle_box", "floor"} <= set(shapes)
    foot = shapes["foot_collision"]
    assert foot.kind == "box" and foot.role == "robot"
    expected = mujoco_box_corners_xz(robot.model, robot.config.to_qpos(q), "foot_collision")
    assert foot.outline.shape == (4, 2)  # a rectangle: the foot turns about y only
    np.testing.assert_allclose(sort_rows(foot.outline), sort_rows(expected), atol=1e-9)
    if which == "q_init":
        # By hand (ortholeg.xml): hip 1.06 m up at x = 0.7 * 0.08 / (pi/2); the foot hangs above the floor.
        assert 0.05 < foot.outline[:, 1].min() < 0.2
        hip_x = 0.7 * 0.08 / (np.pi / 2)
        thigh = shapes["thigh_collision"]
        np.testing.assert_allclose(thigh.ends[np.argmax(thigh.ends[:, 1])], [hip_x, 1.06], atol=1e-9)
    # Capsules are stadiums: every outline vertex is one radius from the projected segment.
    for name in ("thigh_collision", "shank_collision"):
        s = shapes[name]
        a, b = s.ends
        t = np.clip(((s.outline - a) @ (b - a)) / ((b - a) @ (b - a)), 0.0, 1.0)
        dist = np.linalg.norm(s.outline - (a + t[:, None] * (b - a)), axis=1)
        np.testing.assert_allclose(dist, s.radius, atol=1e-9)
    # The obstacle: 0.2 m deep along x centred at x = 0.5, 0.15 m tall, on the floor (z = 0).
    box = shapes["obstacle_box"]
    np.testing.assert_allclose(box.outline.min(axis=0), [0.4, 0.0], atol=1e-12)
    np.testing.assert_allclose(box.outline.max(axis=0), [0.6, 0.15], atol=1e-12)
    floor = shapes["floor"]
    assert floor.kind == "plane" and np.allclose(floor.outline[:, 1], 0.0)


def test_strobe_geometry_options(planned, robot):
    q = np.asarray(planned["q_init"])
    assert {s.role for s in strobe_geometry(robot, q, which="robot")} == {"robot"}
    assert {s.role for s in strobe_geometry(robot, q, which="obstacles")} == {"obstacle"}
    top = {s.name: s for s in strobe_geometry(robot, q, plane="xy", which="obstacles")}
    assert "floor" not in top  # the floor is the drawing's own plane seen from above
    np.testing.assert_allclose(top["obstacle_box"].outline.min(axis=0), [0.4, -0.25], atol=1e-12)
    with pytest.raises(FoamError, match="plane"):
        strobe_geometry(robot, q, plane="ab")
    assert robot_kind(robot) == "sagittal"


# -- command line ----------------------------------------------------------------------------------------------
def test_cli_entry_point(planned, tmp_path, capsys):
    result = tmp_path / "r.json"
    result.write_text(json.dumps(planned))
    assert figures.main([str(result), str(tmp_path / "out"), "--format", "svg", "--dpi", "60"]) == 0
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["foam.svg", "rosary.svg", "strobe.svg"]
    assert "wrote" in capsys.readouterr().out
    assert figures.main([str(tmp_path / "missing.json"), str(tmp_path / "out")]) == 2
    assert "result file not found" in capsys.readouterr().err


def test_figures_find_the_result_s_scene_as_replay_does(planned, tmp_path, capsys):
    """figures read only the result's 'mjcf' and never its model_hash: a result naming another scene (step_up's file
    instead of the obstacle's) drew its strobe over that scene's step with exit 0, where replay, export and verify
    refuse it; and a result moved together with its models (its absolute 'mjcf' gone, its 'mjcf_relative' still
    right) could not be drawn at all. Both now go as for replay."""
    other = dict(planned, mjcf=str(Path(planned["mjcf"]).with_name("step_up.xml")))
    other.pop("mjcf_relative")
    (tmp_path / "other.json").write_text(json.dumps(other))
    assert figures.main([str(tmp_path / "other.json"), str(tmp_path / "out"), "--dpi", "60"]) == 2
    err = capsys.readouterr().err.strip()
    assert "field 'mjcf' names" in err and "compiles to a different model" in err and "\n" not in err, err
    assert not (tmp_path / "out").exists()
    shutil.copytree(Path(planned["mjcf"]).parent, tmp_path / "moved" / "models")
    moved = dict(planned, mjcf=str(tmp_path / "nowhere" / "obstacle.xml"), mjcf_relative="models/obstacle.xml")
    (tmp_path / "moved" / "r.json").write_text(json.dumps(moved))
    assert figures.main([str(tmp_path / "moved" / "r.json"), str(tmp_path / "out"), "--format", "svg", "--dpi", "60"]) == 0
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["foam.svg", "rosary.svg", "strobe.svg"]


def test_a_dpi_beyond_600_or_below_10_is_refused_before_any_drawing(planned, tmp_path, capsys):
    """--dpi 100000 ended in a MemoryError (exit 1) after creating the output folder; --dpi 1 to 6 in FreeType's
    'invalid ppem value' (exit 1, an empty folder left): an 8 pt legend is under a pixel high. The lowest, 10, draws."""
    result = tmp_path / "r.json"
    result.write_text(json.dumps(planned))
    for dpi in ("0", "1", "6", "9", "601", "100000"):
        assert figures.main([str(result), str(tmp_path / "out"), "--dpi", dpi]) == 2
        err = capsys.readouterr().err
        assert err.strip() == f"foam-mj: error: --dpi must be in [10, 600], got {dpi}"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]
    assert figures.main([str(result), str(tmp_path / "out"), "--dpi", "10"]) == 0 and any((tmp_path / "out").iterdir())


def test_missing_matplotlib_says_how_to_install(planned, tmp_path, monkeypatch, capsys):
    for name in [m for m in sys.modules if m == "matplotlib" or m.startswith(("matplotlib.", "mpl_toolkits"))]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # makes `import matplotlib` raise ImportError
    with pytest.raises(FoamError) as err:
        write_figures(planned, tmp_path)
    assert str(err.value) == "figures need matplotlib: pip install 'foam-mj[figures]'" == MISSING_MATPLOTLIB
    assert not any(tmp_path.iterdir())
    result = tmp_path / "r.json"
    result.write_text(json.dumps(planned))
    assert figures.main([str(result), str(tmp_path / "out")]) == 2
    assert "pip install 'foam-mj[figures]'" in capsys.readouterr().err


# -- walker: the top-down map ----------------------------------------------------------------------------------
WALKER_XML = """
<mujoco model="synthetic walker">
  <custom><text name="foam_mj:configuration" data="base_x base_y base_yaw"/></custom>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <geom name="wall_south" type="box" pos="2 -0.05 0.5" size="2 0.05 0.5"/>
    <geom name="wall_north" type="box" pos="2 3.05 0.5" size="2 0.05 0.5"/>
    <geom name="block" type="box" pos="2 1.0 0.5" size="0.2 1.0 0.5"/>
    <geom name="slanted" type="box" pos="1.0 2.3 0.5" size="0.4 0.08 0.5" euler="0 0 0.6"/>
    <body name="walker" pos="0 0 0.4">
      <joint name="base_x" type="slide" axis="1 0 0" range="-1 5"/>
      <joint name="base_y" type="slide" axis="0 1 0" range="-1 4"/>
      <joint name="base_yaw" type="hinge" axis="0 0 1" range="-3.2 3.2"/>
      <geom name="frame" type="box" size="0.3 0.25 0.3"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_synthetic_walker_gets_a_top_down_map(tmp_path):
    """A planar mobile base (slides along x and y, hinge about z) in a small MJCF written here: the
    strobe is drawn from above and the map shows walls, foam footprint, rosary and paths."""
    xml = tmp_path / "walker.xml"
    xml.write_text(WALKER_XML)
    robot = RobotModel.from_xml(xml)
    assert robot_kind(robot) == "planar_base"
    way = np.array([[0.5, 0.5, 0.0], [1.2, 1.6, 0.4], [2.0, 2.5, 0.2], [3.6, 2.2, 1.0]])
    rng = np.random.default_rng(0)
    foam_c = np.column_stack([rng.uniform(0, 4, 200), rng.uniform(0, 3, 200), rng.uniform(-1, 1, 200)])
    times, qpos = smooth_trajectory(way, robot, 3.0)
    doc = {
        "format": "foam-mj/result", "version": 1, "mjcf": str(xml), "q_init": way[0].tolist(), "q_goal": way[-1].tolist(),
        "foam": {"centers": foam_c.tolist(), "radii": rng.uniform(0.1, 0.3, 200).tolist(), "parents": [-1] + list(range(199))},
        "rosary": {"centers": way.tolist(), "radii": [0.6, 0.7, 0.7, 0.9]},
        "paths": {"centre": {"waypoints": way.tolist()}, "gradient": {"waypoints": way.tolist(), "qpos": qpos.tolist(), "times": times.tolist()}},
    }
    written = write_figures(doc, tmp_path / "figs", dpi=60)
    assert [p.name for p in written] == ["foam.png", "rosary.png", "strobe.png", "joints.png", "map.png"]
    for p in written:
        check_png(p, min_px=150)
    walls = {s.name: s for s in strobe_geometry(robot, way[0])}
    np.testing.assert_allclose(walls["block"].outline.min(axis=0), [1.8, 0.0], atol=1e-12)
    np.testing.assert_allclose(walls["block"].outline.max(axis=0), [2.2, 2.0], atol=1e-12)
    np.testing.assert_allclose(walls["frame"].centre, [0.5, 0.5], atol=1e-12)  # the base at q_init's (x, y)
    assert len(walls["slanted"].outline) == 4  # a rotated rectangle


@pytest.mark.skipif(not (SCENARIOS / "walker_corridor.toml").exists(), reason="the walker_corridor scenario is not there yet")
def test_walker_corridor_figures(tmp_path):
    doc = plan_json(tmp_path, "walker_corridor")
    written = write_figures(doc, tmp_path / "figs", dpi=80)
    names = [p.name for p in written]
    assert "map.png" in names and "strobe.png" in names
    for p in written:
        check_png(p, min_px=150)


ARM_3D = """<mujoco><worldbody><geom name="post" type="box" pos="0.6 0 0.3" size="0.05 0.05 0.3"/>
  <body name="turret" pos="0 0 0.1" quat="0.9238795 0 0 0.3826834"><joint name="yaw" axis="0 0 1" range="-170 170"/>
    <geom type="cylinder" size="0.06 0.04"/>
    <body name="upper" pos="0 0 0.06"><joint name="pitch" axis="{pitch}" range="-100 100"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0.3" size="0.04"/></body></body></worldbody></mujoco>"""


@pytest.mark.parametrize(("pitch", "kind"), [("1 0 0", "sagittal"), ("0 0 1", "planar_base")], ids=["3-D arm", "SCARA"])
def test_only_a_base_sliding_in_x_and_y_gets_a_map(tmp_path, pitch, kind):
    """A 3-D arm (a yaw hinge, then a pitch hinge turned 45 degrees about z, oblique in the world) was taken for a
    mobile base: its joint angles were drawn as a top-down 'map' of bubbles in metres. Only configuration
    joints that all move in the floor plane make a planar robot, and only x and y slides make a map."""
    from foam_mj.figure_geometry import has_xy_base

    xml = tmp_path / "arm.xml"
    xml.write_text(ARM_3D.format(pitch=pitch))
    robot = RobotModel.from_xml(xml)
    assert robot_kind(robot) == kind and not has_xy_base(robot)
    walker = tmp_path / "walker.xml"
    walker.write_text(WALKER_XML)
    assert has_xy_base(RobotModel.from_xml(walker))


ONE_JOINT_XML = """
<mujoco model="one joint">
  <worldbody>
    <geom name="ground" type="plane" size="0 0 0.1"/>
    <geom name="wall" type="box" size="0.05 0.5 0.5" pos="2 0 1"/>
    <body name="slider" pos="0 0 1">
      <joint name="x" type="slide" axis="1 0 0" range="0 1.5"/>
      <geom name="probe" type="sphere" size="0.05" mass="1"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_one_joint_robot_gets_its_figures(tmp_path, capsys):
    """plan --figures of a one-joint slider ended with exit 1 (matplotlib's IndexError: a disc centred on one number):
    its foam and rosary are drawn on the x axis of a plane."""
    (tmp_path / "one.xml").write_text(ONE_JOINT_XML)
    out = tmp_path / "one.json"
    assert cli.main(["plan", "--mjcf", str(tmp_path / "one.xml"), "--start", "0.1", "--goal", "1.2", "--smoother", "convex",
                     "--no-replay", "--no-rrd", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    written = write_figures(doc, tmp_path / "figs")
    assert {p.name for p in written} >= {"foam.png", "rosary.png"}
    for p in written:
        check_png(p)


def test_a_one_joint_robots_rosary_draws_the_joint_against_the_path_parameter(tmp_path, capsys):
    """The one-joint rosary and foam figures drew the line of the joint on a plane's x axis, their y axis empty
    (y = 0, no label). The rosary now draws the joint (y, labelled with it) against the path parameter s in [0, 1]
    (x): each path from q_init at s = 0 to q_goal at s = 1, its rosary's bubbles as bands of the joint holding it;
    the foam draws each bubble's interval at the height of its radius (y: the bubble radius)."""
    (tmp_path / "one.xml").write_text(ONE_JOINT_XML)
    out = tmp_path / "one.json"
    assert cli.main(["plan", "--mjcf", str(tmp_path / "one.xml"), "--start", "0.1", "--goal", "1.2", "--smoother", "convex",
                     "--no-replay", "--no-rrd", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    mpl = figures._matplotlib()
    robot = RobotModel.from_xml(doc["mjcf"])
    sel = figures._read_paths(doc, robot, None)
    labels = figures._coord_labels(robot)
    _, title, ros, paths = figures._rosary_groups(doc, sel)[0]
    ax = figures._fig_rosary(mpl, doc, robot, paths, labels, ros, title).axes[0]
    assert ax.get_ylabel() == labels[0] and "path parameter" in ax.get_xlabel()
    drawn = {line.get_label(): line for line in ax.get_lines()}
    for p in paths:
        s, q = drawn[p.label].get_xdata(), drawn[p.label].get_ydata()
        assert s[0] == 0.0 and s[-1] == 1.0 and np.all(np.diff(s) >= 0)
        assert q[0] == pytest.approx(0.1) and q[-1] == pytest.approx(1.2)
        c, r = ros
        assert all(np.any(np.abs(v - c[:, 0]) <= r + 1e-9) for v in q)  # every point inside a bubble's band
    lo, hi = ax.get_ylim()
    assert lo <= 0.1 and hi >= 1.2
    foam = figures._fig_foam(mpl, doc, labels).axes[0]
    assert foam.get_xlabel() == labels[0] and "radius" in foam.get_ylabel()
    assert foam.get_ylim()[1] >= max(doc["foam"]["radii"])


@pytest.mark.parametrize("edit, words", [
    (lambda d: d["paths"]["centre"]["rosary"]["radii"].__setitem__(0, float("nan")), "path 'centre': field 'rosary': centers must be finite"),
    (lambda d: d["rosary"]["radii"].__setitem__(2, -1.0), "field 'rosary': centers must be finite numbers and radii finite numbers > 0"),
    (lambda d: d["foam"]["centers"][5].__setitem__(0, float("inf")), "field 'foam': centers must be finite numbers and radii finite numbers > 0"),
    (lambda d: d["foam"]["radii"].__setitem__(5, float("nan")), "field 'foam': centers must be finite numbers and radii finite numbers > 0"),
])
def test_a_foam_or_rosary_that_cannot_be_drawn_is_refused_before_the_folder_is_made(planned, tmp_path, edit, words, capsys):
    """A NaN rosary radius was matplotlib's 'Axis limits cannot be NaN or Inf' (exit 1) and an infinite foam centre
    'Axis limits -inf, inf cannot be infinite' (exit 1), each after creating the folder; a NaN foam radius was drawn
    without a word. Each is one line, exit 2, and no folder."""
    bad = copy.deepcopy(planned)
    edit(bad)
    result = tmp_path / "r.json"
    result.write_text(json.dumps(bad))
    assert figures.main([str(result), str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]


def test_figures_an_earlier_run_left_in_the_folder_are_named(planned, tmp_path, capsys):
    """Figures of a `--smoother all` result (rosary_adjusted.png, convergence.png), then of a default one into the same
    folder: the first run's were left beside the second's without a word, and the folder looked like one result's. The
    second run names them (stdout) and leaves them; the user's own files are not named."""
    result = tmp_path / "r.json"
    result.write_text(json.dumps(planned))
    out = tmp_path / "figs"
    out.mkdir()
    for name in ("rosary_adjusted.png", "convergence.svg", "notes.png"):  # the earlier run's two, and the user's own
        (out / name).write_bytes(b"x")
    assert figures.main([str(result), str(out)]) == 0
    text = capsys.readouterr().out
    assert (f"note: {out} also holds 2 figure(s) this run did not draw, left by an earlier run: convergence.svg, "
            "rosary_adjusted.png (remove them, or draw into an empty folder)") in text, text
    assert (out / "convergence.svg").exists() and "notes.png" not in text
    assert figures.main([str(result), str(out), "--paths", "centre"]) == 0
    assert "note:" in capsys.readouterr().out  # still there: named again
