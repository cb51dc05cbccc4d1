"""Tests foam_mj.recording: .rrd files written with the Rerun SDK and read back with its RrdReader."""

from __future__ import annotations

from foam_mj.data import model_path

import mujoco
import numpy as np
import pytest
import rerun as rr
from scipy.spatial.transform import Rotation

from foam_mj.bubbles import BubbleOracle
from foam_mj.foam import FoamParams, plan
from foam_mj.model import RobotModel
from foam_mj.recording import Recording, read_blueprint, read_component, read_recording
from foam_mj.replay import replay_dynamic, replay_kinematic
from foam_mj.rosary import Rosary
from foam_mj.trajectory import make_trajectory

from conftest import TWO_LINK_ARM

Q_INIT = [0.2, 0.3, 0.08]
Q_GOAL = [0.45, 0.4536, 1.45]
LEG_BODIES = ("pelvis", "thigh", "shank", "foot")
JOINTS = ("hip_flexion", "knee_flexion", "hip_displacement")

# A scene with one geom of every drawable type (where each lies is in its pos), and a one-joint robot.
SHAPES_XML = """
<mujoco model="shapes">
  <asset><mesh name="tetra" vertex="0 0 0  0.1 0 0  0 0.1 0  0 0 0.1"/></asset>
  <worldbody>
    <geom name="ground" type="plane" size="0 0 0.1"/>
    <geom name="ball" type="sphere" size="0.05" pos="1 0 0.05"/>
    <geom name="can" type="cylinder" size="0.05 0.1" pos="1.5 0 0.1"/>
    <geom name="egg" type="ellipsoid" size="0.05 0.07 0.09" pos="2 0 0.1"/>
    <geom name="rod" type="capsule" fromto="2.5 0 0.1 2.5 0.3 0.1" size="0.02"/>
    <geom name="block" type="box" size="0.1 0.1 0.1" pos="3 0 0.1" euler="0 0 0.5"/>
    <geom name="tetra" type="mesh" mesh="tetra" pos="3.5 0 0"/>
    <body name="slider" pos="0 0 1">
      <joint name="x" type="slide" axis="1 0 0" range="0 1"/>
      <geom name="probe" type="sphere" size="0.05"/>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """One planning run recorded to a file: scene, foam, two paths and their trajectories, kinematic
    replays of both, a dynamic replay of the centre path, and two convergence curves."""
    robot = RobotModel.from_xml(model_path("obstacle.xml"))
    oracle = BubbleOracle(robot, delta=0.005)
    try:
        res = plan(oracle, Q_INIT, Q_GOAL, FoamParams(K=10, r_min=0.07, delta=0.005), seed=0)
    finally:
        oracle.close()
    ros = res.rosary
    paths = {"centre": ros.path(ros.center_waypoints()), "portal": ros.path(ros.portal_waypoints())}
    trajectories = {k: make_trajectory(robot, p, ros) for k, p in paths.items()}
    replays = {k: replay_kinematic(robot, t) for k, t in trajectories.items()}
    replays["centre-dynamic"] = replay_dynamic(robot, trajectories["centre"])
    curves = {"hs": (np.linspace(5.0, 3.0, 60), np.linspace(6.0, 3.5, 60)), "ga": (np.geomspace(5.0, 3.2, 25), np.geomspace(7.0, 3.4, 25))}
    path = tmp_path_factory.mktemp("rec") / "run.rrd"
    strict = rr.strict_mode()
    rr.set_strict_mode(True)  # any rejected log call raises instead of warning
    try:
        with Recording(path) as rec:
            rec.log_scene(robot)
            rec.log_foam(res.foam, ros)
            for name, p in paths.items():
                rec.log_path(name, p)
                rec.log_joint_trajectory(name, trajectories[name])
            for name, r in replays.items():
                rec.log_replay(name, robot, r)
            for name, (best, mean) in curves.items():
                rec.log_convergence(name, best, mean)
    finally:
        rr.set_strict_mode(strict)
    return dict(robot=robot, res=res, paths=paths, trajectories=trajectories, replays=replays, curves=curves, path=path)


def test_every_bubble_and_the_rosary_are_in_the_file(run):
    foam, ros = run["res"].foam, run["res"].rosary
    rows = read_recording(run["path"])
    assert rows["cspace/foam"] == 1 and rows["cspace/rosary"] == 1
    centers = np.array(read_component(run["path"], "cspace/foam", "Ellipsoids3D:centers")[0])
    half = np.array(read_component(run["path"], "cspace/foam", "Ellipsoids3D:half_sizes")[0])
    assert len(centers) == foam.size
    assert np.allclose(centers, foam.centers, atol=1e-6)
    assert np.allclose(half, np.repeat(foam.radii[:, None], 3, axis=1), atol=1e-6)  # spheres
    rosary = np.array(read_component(run["path"], "cspace/rosary", "Ellipsoids3D:centers")[0])
    assert len(rosary) == ros.k and np.allclose(rosary, ros.centers, atol=1e-6)
    for key, q in (("q_init", Q_INIT), ("q_goal", Q_GOAL)):
        assert np.allclose(read_component(run["path"], f"cspace/{key}", "Points3D:positions")[0], [q], atol=1e-6)
    labels = read_component(run["path"], "cspace/axes", "Arrows3D:labels")[0]
    assert labels == list(JOINTS)


def test_every_path_and_trajectory_is_in_the_file(run):
    rows = read_recording(run["path"], static=False)
    for name, p in run["paths"].items():
        strips = read_component(run["path"], f"cspace/paths/{name}", "LineStrips3D:strips")
        assert len(strips) == 1 and np.allclose(strips[0][0], p, atol=1e-6)
        tr = run["trajectories"][name]
        assert rows[f"plots/joints/{name}"] == len(tr)  # one row per frame, a series per joint named after it
        assert read_component(run["path"], f"plots/joints/{name}", "SeriesLines:names") == [list(JOINTS)]
        values = np.array(read_component(run["path"], f"plots/joints/{name}", "Scalars:scalars"))
        assert np.allclose(values, tr.joint_positions)
        assert rows[f"cspace/trajectories/{name}/now"] == len(tr)


def test_a_leg_pose_for_every_replayed_frame(run):
    rows = read_recording(run["path"], static=False)
    static = read_recording(run["path"], static=True)
    for name, replay in run["replays"].items():
        assert rows[f"plots/clearance/{name}"] == replay.n_frames
        for k, body in enumerate(LEG_BODIES):
            entity = f"world/leg/{name}/{body}"
            assert rows[entity] == replay.n_frames
            xyz = np.array(read_component(run["path"], entity, "Transform3D:translation")).reshape(-1, 3)
            assert np.allclose(xyz, replay.poses.xpos[:, k], atol=1e-6)
        assert static[f"world/leg/{name}/foot/foot_collision"] == 1
        assert static[f"world/leg/{name}/thigh/thigh_visual"] == 1
    tracking = np.array(read_component(run["path"], "plots/tracking/centre-dynamic", "Scalars:scalars"))
    assert np.allclose(tracking, run["replays"]["centre-dynamic"].error)
    assert not any(e.startswith("world/contacts") for e in rows)  # the centre path touches nothing


def test_recorded_poses_place_the_geoms_where_mujoco_does(run):
    """Compose the file's body transform and the geom's static transform (Rerun's x, y, z, w
    quaternions) and compare with MuJoCo's geom position and orientation."""
    robot, replay = run["robot"], run["replays"]["centre"]
    m = robot.model
    d = mujoco.MjData(m)
    t_body = np.array(read_component(run["path"], "world/leg/centre/shank", "Transform3D:translation")).reshape(-1, 3)
    q_body = np.array(read_component(run["path"], "world/leg/centre/shank", "Transform3D:quaternion")).reshape(-1, 4)
    t_geom = np.array(read_component(run["path"], "world/leg/centre/shank/shank_collision", "Transform3D:translation")).reshape(3)
    q_geom = np.array(read_component(run["path"], "world/leg/centre/shank/shank_collision", "Transform3D:quaternion")).reshape(4)
    g = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "shank_collision")
    for i in (0, replay.n_frames // 2, replay.n_frames - 1):
        d.qpos[:] = replay.qpos[i]
        mujoco.mj_forward(m, d)
        rb = Rotation.from_quat(q_body[i])
        assert np.allclose(t_body[i] + rb.apply(t_geom), d.geom_xpos[g], atol=1e-5)
        assert np.allclose((rb * Rotation.from_quat(q_geom)).as_matrix(), d.geom_xmat[g].reshape(3, 3), atol=1e-5)


def test_convergence_curves_and_scene(run):
    rows = read_recording(run["path"], static=False)
    for name, (best, mean) in run["curves"].items():
        assert rows[f"plots/convergence/{name}/best"] == len(best)
        assert rows[f"plots/convergence/{name}/mean"] == len(mean)
        got = np.array(read_component(run["path"], f"plots/convergence/{name}/best", "Scalars:scalars")).ravel()
        assert np.allclose(got, best)
    static = read_recording(run["path"], static=True)
    assert static["world/scene/floor"] == 1 and static["world/scene/obstacle_box"] == 1
    box = read_component(run["path"], "world/scene/obstacle_box", "Boxes3D:half_sizes")[0]
    assert np.allclose(box, [[0.1, 0.25, 0.075]], atol=1e-6)
    assert np.allclose(read_component(run["path"], "world/scene/obstacle_box", "Transform3D:translation")[0], [0.5, 0, 0.075], atol=1e-6)


def test_the_blueprint_is_stored(run):
    views = {(v["class"], v["origin"]) for v in read_blueprint(run["path"])}
    assert {("3D", "world"), ("3D", "cspace"), ("TimeSeries", "plots/joints"), ("TimeSeries", "plots/convergence")} <= views


def _unpack(packed) -> tuple[int, int, int, int]:
    """Rerun's packed 0xRRGGBBAA colour as (r, g, b, a)."""
    return tuple(int(packed) >> s & 0xFF for s in (24, 16, 8, 0))


def test_each_path_name_has_its_own_palette_colour_on_its_curves_and_plots(run):
    """A path of the papers keeps its place in the palette (centre: the first colour, in every recording); any other
    name has a colour of its own, a function of the name alone."""
    from foam_mj.recording import PATH_PALETTE, path_color

    palette = [tuple(int(round(c * 255)) for c in rgb) + (255,) for rgb in PATH_PALETTE]
    expected = {"centre": palette[0], "portal": tuple(path_color("portal")), "centre-dynamic": tuple(path_color("centre-dynamic"))}
    assert len(set(expected.values())) == 3
    for name, color in expected.items():
        assert _unpack(read_component(run["path"], f"plots/clearance/{name}", "SeriesLines:colors")[0][0]) == color
        assert _unpack(read_component(run["path"], f"world/traces/{name}", "LineStrips3D:colors")[0][0]) == color
    for name in run["paths"]:
        assert _unpack(read_component(run["path"], f"cspace/paths/{name}", "LineStrips3D:colors")[0][0]) == expected[name]
        joints = [_unpack(c) for c in read_component(run["path"], f"plots/joints/{name}", "SeriesLines:colors")[0]]
        assert joints[0] == expected[name] and len(set(joints)) == len(JOINTS)


def test_a_custom_path_keeps_its_colour_whatever_other_paths_a_recording_holds(tmp_path, run):
    """A custom name took the first palette colour not yet taken: 'portal' was orange after 'centre' and red alone, so
    the same path changed colour between two recordings. Its colour is now the same in both, whatever was logged
    before it, and never a built-in path's palette colour."""
    from foam_mj.recording import PATH_PALETTE

    colors = []
    for i, names in enumerate((["centre", "portal"], ["portal"], ["ga", "hs", "zeta", "portal"])):
        path = tmp_path / f"order{i}.rrd"
        with Recording(path) as rec:
            for name in names:
                rec.log_path(name, run["paths"]["portal"])
        colors.append(_unpack(read_component(path, "cspace/paths/portal", "LineStrips3D:colors")[0][0]))
    assert len(set(colors)) == 1
    assert colors[0][:3] not in {tuple(int(round(c * 255)) for c in rgb) for rgb in PATH_PALETTE}


def test_a_tinted_robot_is_drawn_translucent_in_its_paths_colour(tmp_path, run):
    from foam_mj.recording import TINT_ALPHA

    path = tmp_path / "tint.rrd"
    with Recording(path) as rec:
        rec.log_replay("convex", run["robot"], run["replays"]["centre"], tint=True)
        color = rec.path_color("convex")
        with pytest.raises(ValueError, match="`tint` must be True or False"):
            rec.log_replay("x", run["robot"], run["replays"]["centre"], tint="yes")
    drawn = read_component(path, "world/leg/convex/foot/foot_visual", "Boxes3D:colors")[0][0]
    assert drawn == int.from_bytes(bytes([*color[:3], round(TINT_ALPHA * 255)]), "big")


def test_every_geom_type_is_drawn(tmp_path):
    (tmp_path / "shapes.xml").write_text(SHAPES_XML)
    robot = RobotModel.from_xml(tmp_path / "shapes.xml")
    path = tmp_path / "shapes.rrd"
    with Recording(path) as rec:
        rec.log_scene(robot)
    static = read_recording(path, static=True)
    expected = {
        "ground": "Boxes3D:half_sizes",
        "ball": "Ellipsoids3D:half_sizes",
        "can": "Cylinders3D:lengths",
        "egg": "Ellipsoids3D:half_sizes",
        "rod": "Capsules3D:lengths",
        "block": "Boxes3D:half_sizes",
        "tetra": "Mesh3D:vertex_positions",
    }
    for geom, component in expected.items():
        assert static[f"world/scene/{geom}"] == 1
        assert read_component(path, f"world/scene/{geom}", component), geom
    assert "world/scene/probe" not in static  # the robot's geom is not scenery
    assert np.allclose(read_component(path, "world/scene/rod", "Capsules3D:lengths")[0], [0.3], atol=1e-6)
    assert len(read_component(path, "world/scene/tetra", "Mesh3D:vertex_positions")[0]) == 4


def test_contacts_are_recorded(tmp_path, run):
    robot = run["robot"]
    a, b = np.array(Q_INIT), np.array(Q_GOAL)
    fake = Rosary(((a + b) / 2)[None], np.array([np.linalg.norm(b - a)]), a, b)  # not certified: hits the box
    replay = replay_dynamic(robot, make_trajectory(robot, fake.path(np.empty((0, 3))), fake), feedforward="gravity")
    assert replay.contacts
    path = tmp_path / "contacts.rrd"
    with Recording(path) as rec:
        rec.log_replay("straight", robot, replay)
    points = read_component(path, "world/contacts/straight", "Points3D:positions")
    assert sum(len(p) for p in points) == len(replay.contacts)


def test_bad_calls_raise_clear_errors(tmp_path, run):
    with pytest.raises(ValueError, match="must end in .rrd"):
        Recording(tmp_path / "x.txt")
    with pytest.raises(ValueError, match="folder does not exist"):
        Recording(tmp_path / "missing" / "x.rrd")
    rec = Recording(tmp_path / "bad.rrd")
    try:
        with pytest.raises(ValueError, match="`name`"):
            rec.log_path("centre path", run["paths"]["centre"])
        with pytest.raises(ValueError, match="dimension 1 or more"):
            rec.log_path("p0", np.zeros((5, 0)))
        with pytest.raises(ValueError, match="same length"):
            rec.log_convergence("hs", [3.0, 2.0], [4.0])
        with pytest.raises(ValueError, match="`best`"):
            rec.log_convergence("hs", [])
        with pytest.raises(ValueError, match="`foam` must be a Foam"):
            rec.log_foam(run["res"].rosary)
        with pytest.raises(ValueError, match="`replay` must be"):
            rec.log_replay("x", run["robot"], run["trajectories"]["centre"])
        # another robot's replay: its poses, read by body id, drew that robot's geoms in the leg's poses, silently
        arm = RobotModel.from_xml(TWO_LINK_ARM)
        with pytest.raises(ValueError, match=r"^`replay` is not a replay of `robot` \(arm.xml\): its bodies \['pelvis', 'thigh', 'shank', "
                                             r"'foot'\] and qpos width 3, the robot's bodies at those ids \['body1', 'body2', "
                                             r"'\(none: id 3\)', '\(none: id 4\)'\] and nq = 2$"):
            rec.log_replay("x", arm, run["replays"]["centre"])
        with pytest.raises(ValueError, match=r"^`robot` must be a RobotModel, got BubbleOracle$"):
            rec.log_replay("x", BubbleOracle(run["robot"], 0.005), run["replays"]["centre"])
    finally:
        rec.close()
    with pytest.raises(ValueError, match="is closed"):
        rec.log_path("late", run["paths"]["centre"])
    assert read_recording(tmp_path / "bad.rrd") == {"world": 1, "cspace": 1}


def test_a_recording_reaches_its_file_only_complete(tmp_path, run):
    rec = Recording(tmp_path / "open.rrd")
    rec.log_path("centre", run["paths"]["centre"])
    assert list(tmp_path.iterdir()) == []  # nothing on disk while it is open
    rec.close()
    assert read_recording(tmp_path / "open.rrd")["cspace/paths/centre"] == 1
    with pytest.raises(RuntimeError), Recording(tmp_path / "failed.rrd") as rec:
        rec.log_path("centre", run["paths"]["centre"])
        raise RuntimeError("boom")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["open.rrd"]  # an error while logging leaves no file


def test_more_than_three_joints_are_drawn_on_the_first_three(tmp_path):
    """A bubble of a 5-joint robot projects to a ball of the same radius on any three coordinates."""
    from foam_mj.foam import Foam

    rng = np.random.default_rng(0)
    c = rng.random((6, 5))
    with Recording(tmp_path / "five.rrd") as rec:
        rec.log_foam(Foam(c, np.full(6, 0.1), np.array([-1, 0, 1, 2, 3, 4]), c[0], c[-1]))
        rec.log_path("p5", c)
    centers = np.array(read_component(tmp_path / "five.rrd", "cspace/foam", "Ellipsoids3D:centers")[0])
    np.testing.assert_allclose(centers, c[:, :3], rtol=1e-6)
    assert read_recording(tmp_path / "five.rrd").get("cspace/paths/p5") == 1


MATERIALS_XML = """
<mujoco model="materials">
  <asset>
    <material name="blue" rgba="0 0 1 1"/>
    <mesh name="tetra" vertex="0 0 0  0.1 0 0  0 0.1 0  0 0 0.1"/>
  </asset>
  <worldbody>
    <geom name="by_material" type="mesh" mesh="tetra" material="blue"/>
    <geom name="own_rgba" type="box" size="0.1 0.1 0.1" pos="1 0 0" material="blue" rgba="1 0 0 1"/>
    <geom name="plain" type="sphere" size="0.1" pos="2 0 0"/>
    <geom name="hull" type="sphere" size="0.1" pos="3 0 0" group="3"/>
    <body name="slider" pos="0 0 1">
      <joint name="x" type="slide" axis="1 0 0" range="0 1"/>
      <geom name="probe" type="sphere" size="0.05"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_geoms_are_drawn_in_the_colours_mujoco_gives_them(tmp_path):
    """Menagerie's meshes are coloured by their materials alone (rgba left at MuJoCo's default grey): every robot was
    drawn grey, and their collision hulls, grey and opaque, hid the visual meshes. A geom takes its material's rgba
    unless it sets its own, as MuJoCo's renderer does."""
    (tmp_path / "materials.xml").write_text(MATERIALS_XML)
    robot = RobotModel.from_xml(tmp_path / "materials.xml")
    path = tmp_path / "materials.rrd"
    with Recording(path) as rec:
        rec.log_scene(robot)
    packed = {  # Rerun's colours are 0xRRGGBBAA
        "by_material": read_component(path, "world/scene/by_material", "Mesh3D:albedo_factor")[0][0],
        "own_rgba": read_component(path, "world/scene/own_rgba", "Boxes3D:colors")[0][0],
        "plain": read_component(path, "world/scene/plain", "Ellipsoids3D:colors")[0][0],
        "hull": read_component(path, "world/scene/hull", "Ellipsoids3D:colors")[0][0],
    }
    # A geom in a group MuJoCo's viewer hides (group 3: Menagerie's collision hulls) is translucent: alpha 0.4.
    assert packed == {"by_material": 0x0000FFFF, "own_rgba": 0xFF0000FF, "plain": 0x808080FF, "hull": 0x80808066}


def test_a_one_joint_robot_is_planned_and_recorded(tmp_path, capsys):
    """A slider with one joint planned, then `plan` ended with exit 1 at the recording ("configurations of dimension 2
    or more to draw"), after all its work and before writing its JSON: its configuration space is now a line."""
    from foam_mj.cli import main

    (tmp_path / "shapes.xml").write_text(SHAPES_XML)
    rrd, out = tmp_path / "one.rrd", tmp_path / "one.json"
    assert main(["plan", "--mjcf", str(tmp_path / "shapes.xml"), "--start", "0.1", "--goal", "0.9", "--smoother", "convex",
                 "--rrd", str(rrd), "--json", str(out)]) == 0, capsys.readouterr().err
    assert out.exists()
    centers = np.array(read_component(rrd, "cspace/foam", "Ellipsoids3D:centers")[0])
    assert len(centers) >= 1 and np.all(centers[:, 1:] == 0) and np.all((centers[:, 0] >= 0) & (centers[:, 0] <= 1))
    strip = np.array(read_component(rrd, "cspace/paths/convex", "LineStrips3D:strips")[0][0])
    np.testing.assert_allclose(strip[[0, -1]], [[0.1, 0, 0], [0.9, 0, 0]], atol=1e-6)
    assert read_component(rrd, "cspace/axes", "Arrows3D:labels")[0] == ["x"]
    assert read_recording(rrd, static=False)["world/leg/convex/slider"] >= 2


def test_a_paths_joint_series_share_one_row_per_frame(tmp_path, run):
    """Each joint's series was its own entity: every frame's time, frame and row id stored once per joint and per plot
    (walker_two_routes: 45.6 MB, joints, tracking, torque and power 13.4 MB each before compression). A path's joints
    now share one entity per plot, a row of n values per frame: under two thirds of the bytes for three joints."""
    tr = run["trajectories"]["centre"]
    one = tmp_path / "one.rrd"
    with Recording(one) as rec:
        rec.log_joint_trajectory("centre", tr)
    with Recording(tmp_path / "apart.rrd") as rec:  # the former layout, for scale
        index = [rr.TimeColumn("time", duration=tr.times), rr.TimeColumn("frame", sequence=np.arange(len(tr)))]
        for j, joint in enumerate(JOINTS):
            rec._scalars(f"plots/joints/centre/{joint}", index, tr.joint_positions[:, j], [joint], rec.path_color("centre")[None])
    assert read_recording(one, static=False)["plots/joints/centre"] == len(tr)
    trajectory_only = [e for e in read_recording(one) if e.startswith("plots/")]
    assert trajectory_only == ["plots/joints/centre"]
    sizes = {p.name: sum(ch.to_record_batch().nbytes for ch in _chunks(p) if str(ch.entity_path).startswith("/plots/"))
             for p in (one, tmp_path / "apart.rrd")}
    assert sizes["one.rrd"] < 0.67 * sizes["apart.rrd"], sizes


def _chunks(path):
    from rerun.chunk import RrdReader

    return list(RrdReader(path).stream())


# A two-link arm whose links are triangle meshes (an .obj written by trimesh), and a post to plan around.
MESH_ARM_XML = """
<mujoco model="mesh_arm">
  <compiler angle="radian"/>
  <asset><mesh name="link" file="link.obj"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <geom name="post" type="box" size="0.05 0.05 0.3" pos="0.45 0.3 0.3"/>
    <body name="upper" pos="0 0 0.3">
      <joint name="shoulder" type="hinge" axis="0 0 1" range="-2 2"/>
      <geom name="upper_mesh" type="mesh" mesh="link" pos="0.15 0 0" euler="0 1.5708 0"/>
      <body name="fore" pos="0.3 0 0">
        <joint name="elbow" type="hinge" axis="0 0 1" range="-2 2"/>
        <geom name="fore_mesh" type="mesh" mesh="link" pos="0.12 0 0" euler="0 1.5708 0"/>
        <geom name="tip" type="sphere" size="0.03" pos="0.26 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
ARM_Q_INIT, ARM_Q_GOAL = [-1.0, 0.3], [1.2, -0.3]


def mesh_arm_xml(folder):
    """The mesh arm's MJCF in ``folder``, with its link mesh: a capsule of 0.2 m, 0.03 m radius, about 33k triangles."""
    trimesh = pytest.importorskip("trimesh")
    trimesh.creation.capsule(height=0.2, radius=0.03, count=[128, 128]).export(folder / "link.obj")
    (folder / "mesh_arm.xml").write_text(MESH_ARM_XML)
    return folder / "mesh_arm.xml"


@pytest.fixture(scope="module")
def mesh_arm(tmp_path_factory):
    robot = RobotModel.from_xml(mesh_arm_xml(tmp_path_factory.mktemp("arm")))
    oracle = BubbleOracle(robot, delta=0.005)
    try:
        res = plan(oracle, ARM_Q_INIT, ARM_Q_GOAL, FoamParams(K=10, r_min=0.07, delta=0.005), seed=0)
    finally:
        oracle.close()
    ros = res.rosary
    replays = [replay_kinematic(robot, make_trajectory(robot, ros.path(w), ros)) for w in (ros.center_waypoints(), ros.portal_waypoints())]
    return dict(robot=robot, replays=replays)


def test_a_robots_meshes_are_in_the_file_once_whatever_the_number_of_paths(tmp_path, mesh_arm):
    """Every path's robot held its own copy of the mesh geometry (reported for a Menagerie Panda: about 5.5 MB per path). Each mesh
    is now logged once for the main robot and once for the tinted ones, each robot an instance pose of it per frame:
    four more paths weigh less than one more copy of the meshes, and every instance sits at its path's body."""
    robot, replays = mesh_arm["robot"], mesh_arm["replays"]
    m = robot.model
    mesh_bytes = 2 * 4 * (m.mesh_vert.size + m.mesh_face.size)  # one copy of both links' meshes, float32 / int32
    sizes = {}
    for n in (2, 6):
        path = tmp_path / f"paths{n}.rrd"
        with Recording(path) as rec:
            for i in range(n):
                rec.log_replay(f"p{i}", robot, replays[i % 2], tint=i > 0)
        sizes[n] = path.stat().st_size
    assert sizes[6] - sizes[2] < 0.8 * mesh_bytes, (sizes, mesh_bytes)  # was 4 copies more
    path = tmp_path / "paths6.rrd"
    static, timed = read_recording(path, static=True), read_recording(path, static=False)
    meshes = sorted(e for e in static if "_mesh" in e)
    assert meshes == [f"world/meshes/{g}/{b}/{b}_mesh" for g in ("model", "tinted") for b in ("fore", "upper")]
    nv = int(m.mesh_vertnum[0])
    for entity in meshes:
        assert static[entity] == 1 and len(read_component(path, entity, "Mesh3D:vertex_positions")[0]) == nv
    assert "world/leg/p0/upper/upper_mesh" not in static and static["world/leg/p3/fore/tip"] == 1  # primitives per path
    T = max(r.n_frames for r in replays)
    entity = "world/meshes/tinted/fore/fore_mesh"
    assert timed[entity] == T
    rows = read_component(path, entity, "InstancePoses3D:translations")
    assert len(rows) == T and all(len(r) == 5 for r in rows)  # paths p1..p5, one instance each per frame
    g = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "fore_mesh")
    d = mujoco.MjData(m)
    for f in (0, T // 2, T - 1):
        for i, replay in enumerate(replays[(j + 1) % 2] for j in range(5)):
            d.qpos[:] = replay.qpos[min(f, replay.n_frames - 1)]  # a path that ended holds its last pose
            mujoco.mj_kinematics(m, d)
            assert np.allclose(rows[f][i], d.geom_xpos[g], atol=1e-5)
            xyzw = read_component(path, entity, "InstancePoses3D:quaternions")[f][i]
            R = Rotation.from_quat(xyzw).as_matrix()
            assert np.allclose(R, d.geom_xmat[g].reshape(3, 3), atol=1e-5)
    # The mesh is logged as MuJoCo compiled it, in the geom's frame.
    drawn = np.array(read_component(path, entity, "Mesh3D:vertex_positions")[0])
    assert np.allclose(drawn, m.mesh_vert[:nv], atol=1e-6)


def test_a_robot_at_fixed_configurations_is_drawn_there(tmp_path, mesh_arm):
    """A failed plan's recording showed the foam only: the robot is drawn at q_init (model colours) and q_goal
    (translucent red), its bodies where forward kinematics puts them and its meshes as static instances."""
    robot = mesh_arm["robot"]
    path = tmp_path / "ends.rrd"
    with Recording(path) as rec:
        rec.log_configurations(robot, {"q_init": ARM_Q_INIT, "q_goal": ARM_Q_GOAL})
    static = read_recording(path, static=True)
    for key, q in (("q_init", ARM_Q_INIT), ("q_goal", ARM_Q_GOAL)):
        d = robot.set_configuration(np.array(q))
        b = mujoco.mj_name2id(robot.model, mujoco.mjtObj.mjOBJ_BODY, "fore")
        assert np.allclose(read_component(path, f"world/leg/{key}/fore", "Transform3D:translation")[0], d.xpos[b], atol=1e-6)
        g = mujoco.mj_name2id(robot.model, mujoco.mjtObj.mjOBJ_GEOM, "fore_mesh")
        assert np.allclose(read_component(path, f"world/meshes/{key}/fore/fore_mesh", "InstancePoses3D:translations")[0][0], d.geom_xpos[g], atol=1e-6)
        assert static[f"world/leg/{key}/fore/tip"] == 1
    tip = [_unpack(read_component(path, f"world/leg/{k}/fore/tip", "Ellipsoids3D:colors")[0][0]) for k in ("q_init", "q_goal")]
    assert tip[0][3] == 255 and tip[1][3] < 255 and tip[1][0] > tip[1][1]


def test_every_frame_is_recorded_at_its_trajectory_time_to_the_nanosecond(run):
    """The ``time`` timeline holds each frame's time rounded to whole nanoseconds, as a reader joining it with the
    result's ``times`` expects: Rerun's TimeColumn truncates a float array, and 17 of the obstacle centre path's 1,163
    frames (2.05 s among them) were stored 1 ns early, read back and shown as 2.049999999 s."""
    times = {name: tr.times for name, tr in run["trajectories"].items()}
    checked = 0
    for ch in _chunks(run["path"]):
        entity = str(ch.entity_path).lstrip("/")
        name = entity.split("/")[-1] if entity.startswith(("plots/joints/", "plots/clearance/")) else None
        batch = ch.to_record_batch()
        if name not in times or "time" not in batch.schema.names:
            continue
        frame = batch.column("frame").to_numpy()
        ns = batch.column("time").cast("int64").to_numpy()
        assert np.array_equal(ns, np.round(times[name][frame] * 1e9).astype(np.int64)), entity
        checked += len(ns)
    assert checked >= sum(len(t) for t in times.values())
