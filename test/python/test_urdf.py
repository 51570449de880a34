"""The TurtleBot3 Burger xacro: expands with a frame prefix; frames and offsets are TB3's."""
import shutil
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
XACRO_FILE = REPO / "urdf" / "turtlebot3_burger.urdf.xacro"
LAUNCH_FILE = REPO / "launch" / "include" / "robot_description.launch"
LINKS = ["base_footprint", "base_link", "wheel_left_link", "wheel_right_link",
         "caster_back_link", "imu_link", "base_scan"]


def expand(*mappings):
    """Run the xacro command that robot_description.launch runs; return the URDF root."""
    xacro = shutil.which("xacro")
    assert xacro, "xacro is not on PATH (the venv's bin/ or /opt/ros/noetic/bin)"
    result = subprocess.run([xacro, str(XACRO_FILE), *mappings], capture_output=True,
                            text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    return ET.fromstring(result.stdout)


def rpy_matrix(roll, pitch, yaw):
    cr, sr, cp, sp, cy, sy = (np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch),
                              np.cos(yaw), np.sin(yaw))
    return (np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
            @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
            @ np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]]))


def frame_positions(robot):
    """Position of every link's frame in the root link's frame, walking the joint tree."""
    joints = {j.find("child").get("link"): j for j in robot.findall("joint")}
    poses = {}

    def pose_of(link):
        if link not in poses:
            joint = joints.get(link)
            if joint is None:
                poses[link] = (np.eye(3), np.zeros(3))
            else:
                origin = joint.find("origin")
                xyz = np.array([float(v) for v in origin.get("xyz").split()])
                rpy = [float(v) for v in origin.get("rpy").split()]
                rotation, position = pose_of(joint.find("parent").get("link"))
                poses[link] = (rotation @ rpy_matrix(*rpy), rotation @ xyz + position)
        return poses[link]

    return {link.get("name"): pose_of(link.get("name"))[1] for link in robot.findall("link")}


@pytest.fixture(scope="module")
def tb3_0():
    return expand("prefix:=tb3_0")


def test_every_link_carries_the_prefix_and_the_tree_is_rooted_at_base_footprint(tb3_0):
    names = sorted(link.get("name") for link in tb3_0.findall("link"))
    assert names == sorted(f"tb3_0/{name}" for name in LINKS)
    children = {j.find("child").get("link") for j in tb3_0.findall("joint")}
    parents = {j.find("parent").get("link") for j in tb3_0.findall("joint")}
    assert set(names) - children == {"tb3_0/base_footprint"}
    assert parents <= set(names)
    # Joint names stay plain: real robots publish joint_states as wheel_left_joint etc.
    assert {j.get("name") for j in tb3_0.findall("joint")} >= {"wheel_left_joint",
                                                                "wheel_right_joint"}


def test_frames_sit_at_turtlebot3_burger_offsets(tb3_0):
    position = frame_positions(tb3_0)
    base_link = position["tb3_0/base_link"]
    np.testing.assert_allclose(base_link, [0, 0, 0.010], atol=1e-9)
    np.testing.assert_allclose(position["tb3_0/base_scan"] - base_link, [-0.032, 0, 0.172],
                               atol=1e-9)
    np.testing.assert_allclose(position["tb3_0/wheel_left_link"], [0, 0.08, 0.033], atol=1e-9)
    np.testing.assert_allclose(position["tb3_0/wheel_right_link"], [0, -0.08, 0.033],
                               atol=1e-9)
    np.testing.assert_allclose(position["tb3_0/caster_back_link"] - base_link,
                               [-0.081, 0, -0.004], atol=1e-9)


def test_wheels_have_tb3_radius_and_touch_the_ground(tb3_0):
    position = frame_positions(tb3_0)
    for side in ("left", "right"):
        link = tb3_0.find(f"link[@name='tb3_0/wheel_{side}_link']")
        cylinder = link.find("visual/geometry/cylinder")
        radius = float(cylinder.get("radius"))
        assert radius == pytest.approx(0.033)
        assert position[f"tb3_0/wheel_{side}_link"][2] - radius == pytest.approx(0.0, abs=1e-9)


def test_simple_shapes_only_no_meshes(tb3_0):
    assert tb3_0.findall(".//mesh") == []
    assert "package://" not in ET.tostring(tb3_0, encoding="unicode")


def test_empty_prefix_gives_plain_names_and_slashes_are_stripped():
    plain = expand()
    assert sorted(link.get("name") for link in plain.findall("link")) == sorted(LINKS)
    nested = expand("prefix:=/arena_1/tb3_2/")
    assert sorted(link.get("name") for link in nested.findall("link")) == \
        sorted(f"arena_1/tb3_2/{name}" for name in LINKS)


def test_wheel_joint_type_argument():
    assert {j.get("type") for j in expand().findall("joint[@name='wheel_left_joint']")} == \
        {"continuous"}
    fixed = expand("prefix:=tb3_1", "wheel_joint_type:=fixed")
    assert {j.get("type") for j in fixed.findall("joint")} == {"fixed"}


def test_robot_description_launch_passes_its_arguments_to_xacro():
    launch = ET.parse(LAUNCH_FILE).getroot()
    args = {arg.get("name"): arg for arg in launch.findall("arg")}
    assert set(args) == {"ns", "tf_prefix", "wheel_joint_type", "publish_frequency"}
    assert all(arg.get("doc") for arg in args.values())
    assert args["tf_prefix"].get("default") == "$(arg ns)"
    group = launch.find("group")
    assert group.get("ns") == "$(arg ns)"
    command = group.find("param[@name='robot_description']").get("command")
    assert "prefix:=$(arg tf_prefix)" in command
    assert "wheel_joint_type:=$(arg wheel_joint_type)" in command
    assert group.find("node").get("pkg") == "robot_state_publisher"
