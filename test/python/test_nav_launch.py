"""Navigation launch files, checked without starting anything (and without the stock
navigation packages): the stock branch of launch/include/robot_nav.launch loads move_base
(navfn + DWA), amcl and map_server with the same parameter files and per-robot frames as the
built-in branch; every referenced file exists; every argument is documented; the project's
parameter files keep TurtleBot3's values."""
import os
import xml.etree.ElementTree as ElementTree

import pytest
import yaml

roslaunch = pytest.importorskip("roslaunch")

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TB3_PARAMS = os.path.join(REPO, "..", "shared", "external", "turtlebot3_noetic", "turtlebot3_navigation", "param")
LAUNCH_FILES = ["launch/include/robot_nav.launch", "launch/nav.launch", "launch/nav_robots.launch",
                "launch/evaluate.launch", "launch/execute.launch"]


@pytest.fixture(autouse=True)
def package_path(monkeypatch):
    """$(find marl_mrta) resolves to this checkout even without a sourced workspace."""
    monkeypatch.setenv("ROS_PACKAGE_PATH", REPO + os.pathsep + os.environ.get("ROS_PACKAGE_PATH", ""))


def load(launch_file, *args):
    # (file, argv) pairs: roslaunch takes the name:=value arguments from argv.
    config = roslaunch.config.load_config_default([(os.path.join(REPO, launch_file), ["roslaunch"] + list(args))],
                                                  None, verbose=False)
    nodes = {n.namespace + n.name: n for n in config.nodes}
    params = {name: p.value for name, p in config.params.items()}
    return nodes, params


def test_stock_branch_launches_move_base_amcl_with_the_same_files():
    nodes, params = load("launch/include/robot_nav.launch", "ns:=tb3_0", "nav:=stock", "localization:=amcl",
                         "initial_pose_x:=0.5", "initial_pose_y:=4.5")
    move_base = nodes["/tb3_0/move_base"]
    assert (move_base.package, move_base.type) == ("move_base", "move_base")
    amcl = nodes["/tb3_0/amcl"]
    assert (amcl.package, amcl.type) == ("amcl", "amcl")
    assert params["/tb3_0/move_base/base_global_planner"] == "navfn/NavfnROS"
    assert params["/tb3_0/move_base/base_local_planner"] == "dwa_local_planner/DWAPlannerROS"
    # TurtleBot3 Burger values from the parameter files
    assert params["/tb3_0/move_base/DWAPlannerROS/max_vel_x"] == 0.22
    assert params["/tb3_0/move_base/DWAPlannerROS/max_vel_theta"] == 2.75
    assert params["/tb3_0/move_base/controller_frequency"] == 10.0
    assert params["/tb3_0/move_base/local_costmap/rolling_window"] is True
    assert params["/tb3_0/move_base/global_costmap/inflation_radius"] == 1.0
    assert params["/tb3_0/move_base/local_costmap/footprint"] == [[-0.105, -0.105], [-0.105, 0.105],
                                                                  [0.041, 0.105], [0.041, -0.105]]
    # multi-robot frames: the shared map, everything else prefixed, no leading slash
    assert params["/tb3_0/move_base/global_costmap/global_frame"] == "map"
    assert params["/tb3_0/move_base/global_costmap/robot_base_frame"] == "tb3_0/base_footprint"
    assert params["/tb3_0/move_base/local_costmap/global_frame"] == "tb3_0/odom"
    assert params["/tb3_0/move_base/local_costmap/scan/sensor_frame"] == "tb3_0/base_scan"
    assert params["/tb3_0/amcl/odom_frame_id"] == "tb3_0/odom"
    assert params["/tb3_0/amcl/base_frame_id"] == "tb3_0/base_footprint"
    assert params["/tb3_0/amcl/initial_pose_y"] == 4.5
    assert params["/tb3_0/amcl/max_particles"] == 3000
    # relative cmd_vel (stays in the robot namespace), the shared /map
    remaps = dict(move_base.remap_args)
    assert remaps["cmd_vel"] == "cmd_vel"
    assert remaps["map"] == "/map"
    assert dict(amcl.remap_args)["map"] == "/map"


def test_builtin_amcl_gets_the_parameters_stock_amcl_gets():
    args = ["ns:=tb3_0", "localization:=amcl", "initial_pose_x:=0.5", "initial_pose_y:=4.5"]
    builtin_nodes, builtin = load("launch/include/robot_nav.launch", "nav:=builtin", *args)
    stock_nodes, stock = load("launch/include/robot_nav.launch", "nav:=stock", *args)
    amcl = builtin_nodes["/tb3_0/amcl"]
    assert (amcl.package, amcl.type) == ("marl_mrta", "amcl")
    assert (stock_nodes["/tb3_0/amcl"].package, stock_nodes["/tb3_0/amcl"].type) == ("amcl", "amcl")
    amcl_params = {k: v for k, v in builtin.items() if k.startswith("/tb3_0/amcl/")}
    assert amcl_params == {k: v for k, v in stock.items() if k.startswith("/tb3_0/amcl/")}
    assert amcl_params["/tb3_0/amcl/base_frame_id"] == "tb3_0/base_footprint"
    assert amcl_params["/tb3_0/amcl/initial_pose_x"] == 0.5
    assert amcl_params["/tb3_0/amcl/laser_model_type"] == "likelihood_field"
    assert dict(amcl.remap_args) == dict(stock_nodes["/tb3_0/amcl"].remap_args)


def test_builtin_and_stock_get_the_same_parameters():
    _, builtin = load("launch/include/robot_nav.launch", "ns:=tb3_1", "nav:=builtin")
    builtin_nodes, _ = load("launch/include/robot_nav.launch", "ns:=tb3_1", "nav:=builtin")
    _, stock = load("launch/include/robot_nav.launch", "ns:=tb3_1", "nav:=stock", "localization:=fake")
    assert builtin_nodes["/tb3_1/move_base"].package == "marl_mrta"
    assert builtin_nodes["/tb3_1/fake_localization"].package == "marl_mrta"
    # ... but for fake_localization's post-dating of map -> odom: 0 keeps the built-in lock-step
    # lookups exact; stock move_base needs the stock default 0.1 s (docs/guide/navigation.md).
    tolerance = "/tb3_1/fake_localization/transform_tolerance"
    assert (builtin.pop(tolerance), stock.pop(tolerance)) == (0.0, 0.1)
    assert builtin == stock
    assert any(k.startswith("/tb3_1/move_base/DWAPlannerROS/") for k in builtin)


def test_fake_static_localization_sets_the_static_transform_option():
    nodes, params = load("launch/nav.launch", "robots:=2", "nav:=builtin", "localization:=fake_static")
    assert nodes["/tb3_1/fake_localization"].package == "marl_mrta"
    assert params["/tb3_0/fake_localization/static_transform"] is True
    assert params["/tb3_1/fake_localization/static_transform"] is True
    _, default = load("launch/nav.launch", "robots:=2", "nav:=builtin")
    assert "/tb3_0/fake_localization/static_transform" not in default  # stock behaviour: /tf


def test_nav_launch_stock_runs_one_map_server_for_all_robots():
    nodes, _ = load("launch/nav.launch", "robots:=3", "nav:=stock")
    assert nodes["/map_server"].package == "map_server"
    map_file = nodes["/map_server"].args
    assert os.path.isfile(map_file), map_file
    assert {"/tb3_0/move_base", "/tb3_1/move_base", "/tb3_2/move_base"} <= set(nodes)
    assert all(nodes["/tb3_%d/move_base" % i].package == "move_base" for i in range(3))
    nodes, _ = load("launch/nav.launch", "robots:=2", "arenas:=2", "nav:=builtin")
    assert "/arena_1/tb3_1/move_base" in nodes


@pytest.mark.parametrize("launch_args", [["launch/evaluate.launch", "method:=exact"],
                                         ["launch/evaluate.launch", "method:=policy", "policy:=/tmp/actor.pt"],
                                         ["launch/execute.launch", "policy:=/tmp/actor.pt"]])
@pytest.mark.slow
def test_evaluation_launch_files_pass_navigation_lockstep_and_noise_on(launch_args):
    nodes, params = load(*launch_args)
    # Defaults: built-in (a nodelet in the simulator's manager), lock-step, ideal.
    assert nodes["/tb3_0/move_base"].args == "load marl_mrta/MoveBase /sim_manager"
    assert params["/simulator/lockstep"] is True
    nodes, _ = load(*launch_args, "nodelets:=false")
    assert (nodes["/tb3_0/move_base"].package, nodes["/simulator"].package) == ("marl_mrta", "marl_mrta")
    assert params["/simulator/noise_profile"] == "ideal"
    assert params["/simulator/publish_localization"] is True and "/tb3_1/fake_localization" not in nodes
    nodes, params = load(*launch_args, "nav:=stock", "lockstep:=false", "noise_profile:=measured_tb3",
                         "localization:=fake")
    assert nodes["/tb3_0/move_base"].package == "move_base"
    assert nodes["/tb3_1/fake_localization"].package == "fake_localization"
    assert params["/simulator/publish_localization"] is False
    assert params["/simulator/lockstep"] is False
    assert params["/simulator/noise_profile"] == "measured_tb3"
    assert not any(name.endswith("/stock_lockstep") for name in nodes)
    # nav:=stock alone: real time without lock-step.
    nodes, params = load(*launch_args, "nav:=stock")
    assert nodes["/tb3_0/move_base"].package == "move_base"
    assert (params["/simulator/lockstep"], params["/simulator/rtf"]) == (False, 1.0)
    assert not any(name.endswith("/stock_lockstep") for name in nodes)
    # nav:=stock lockstep:=true: a stock_lockstep node per robot answers the ticks for its move_base.
    nodes, params = load(*launch_args, "nav:=stock", "lockstep:=true", "rtf:=0")
    assert params["/simulator/lockstep"] is True
    assert (nodes["/tb3_1/stock_lockstep"].package, nodes["/tb3_1/stock_lockstep"].type) == ("marl_mrta", "stock_lockstep")
    assert sorted(name for name in nodes if name.endswith("/stock_lockstep")) == ["/tb3_0/stock_lockstep",
                                                                                  "/tb3_1/stock_lockstep"]
    assert params["/tb3_0/stock_lockstep/wait_for_amcl"] is False
    _, params = load(*launch_args, "nav:=stock", "lockstep:=true", "rtf:=0", "localization:=amcl")
    assert params["/tb3_1/stock_lockstep/wait_for_amcl"] is True   # amcl's map -> odom is waited for too
    nodes, _ = load(*launch_args, "lockstep:=true")   # the built-in move_base answers its ticks itself
    assert not any(name.endswith("/stock_lockstep") for name in nodes)


@pytest.mark.slow
def test_nodelets_put_the_simulator_and_every_builtin_move_base_in_one_manager():
    nodes, params = load("launch/tasks.launch", "arenas:=2")
    assert nodes["/sim_manager"].package == "nodelet" and nodes["/sim_manager"].args == "manager"
    assert nodes["/simulator"].package == "nodelet"
    assert nodes["/simulator"].args == "load marl_mrta/Simulator /sim_manager"
    assert params["/simulator/lockstep"] is True    # the nodelet reads the node's parameters
    for ns in ("arena_0/tb3_0", "arena_0/tb3_1", "arena_1/tb3_0", "arena_1/tb3_1"):
        move_base = nodes["/%s/move_base" % ns]
        assert (move_base.package, move_base.type) == ("nodelet", "nodelet")
        assert move_base.args == "load marl_mrta/MoveBase /sim_manager"
        assert ["map", "/map"] in move_base.remap_args
        assert params["/%s/move_base/controller_frequency" % ns] == 10.0
    map_server = nodes["/map_server"]
    assert (map_server.package, map_server.type) == ("nodelet", "nodelet")
    assert map_server.args.split()[:3] == ["load", "marl_mrta/MapServer", "/sim_manager"]
    assert map_server.args.split()[3].endswith("maps/lab.yaml")
    assert ["/use_sim_time", "nodelet_load_client_has_no_sim_time"] in map_server.remap_args
    nodes, _ = load("launch/tasks.launch", "nodelets:=false")
    assert "/sim_manager" not in nodes
    assert (nodes["/simulator"].package, nodes["/simulator"].type) == ("marl_mrta", "simulator")
    assert (nodes["/tb3_0/move_base"].package, nodes["/tb3_0/move_base"].type) == ("marl_mrta", "move_base")
    assert (nodes["/map_server"].package, nodes["/map_server"].type) == ("marl_mrta", "map_server")
    # The stock move_base is no nodelet: a node of its own even beside the manager.
    nodes, params = load("launch/tasks.launch", "nav:=stock", "lockstep:=false")
    assert nodes["/tb3_0/move_base"].package == "move_base"
    # ... and the manager starts steps on the next tick, not the next whole second, which it
    # would reach by stepping the paused simulator in one burst that stock move_base cannot follow.
    assert params["/rl_task_allocation_manager/align_period"] == 0.0
    _, params = load("launch/tasks.launch")
    assert params["/rl_task_allocation_manager/align_period"] == 1.0


def test_nav_auto_picks_stock_with_move_base_else_builtin():
    import rospkg
    installed = "move_base" in rospkg.RosPack().list()  # e.g. after make stock-nav, or on Noetic
    nodes, _ = load("launch/nav.launch", "robots:=1")
    assert nodes["/map_server"].package == ("map_server" if installed else "marl_mrta")
    assert nodes["/tb3_0/move_base"].package == ("move_base" if installed else "marl_mrta")


@pytest.mark.parametrize("launch_file", LAUNCH_FILES)
def test_every_argument_is_documented(launch_file):
    root = ElementTree.parse(os.path.join(REPO, launch_file)).getroot()
    undocumented = [a.get("name") for a in root.iter("arg") if a.get("value") is None and not a.get("doc")]
    assert undocumented == []


@pytest.mark.parametrize("name", ["costmap_common_params_burger.yaml", "global_costmap_params.yaml",
                                  "local_costmap_params.yaml", "move_base_params.yaml",
                                  "dwa_local_planner_params_burger.yaml"])
def test_project_parameter_files_keep_turtlebot3_values(name):
    original = os.path.join(TB3_PARAMS, name)
    if not os.path.isfile(original):
        pytest.skip("TurtleBot3 parameter files not found at " + TB3_PARAMS)
    with open(original) as a, open(os.path.join(REPO, "config", "nav", name)) as b:
        assert yaml.safe_load(a) == yaml.safe_load(b)


@pytest.mark.slow
def test_simulator_localization_replaces_the_fake_localization_nodes():
    nodes, params = load("launch/tasks.launch", "arenas:=2")   # the default
    assert params["/simulator/publish_localization"] is True
    assert not [name for name in nodes if name.endswith("/fake_localization")]
    assert "/arena_1/tb3_1/move_base" in nodes
    nodes, params = load("launch/tasks.launch", "arenas:=2", "localization:=fake")
    assert params["/simulator/publish_localization"] is False
    assert len([name for name in nodes if name.endswith("/fake_localization")]) == 4
    # Training on the ROS simulation uses the simulator's localisation.
    nodes, params = load("launch/train.launch", "backend:=ros")
    assert params["/simulator/publish_localization"] is True
    assert nodes["/arena_1/tb3_1/move_base"].args == "load marl_mrta/MoveBase /sim_manager"
    nodes, _ = load("launch/train.launch", "backend:=ros", "nodelets:=false")
    assert nodes["/arena_1/tb3_1/move_base"].package == "marl_mrta"


def test_train_launch_derives_the_managers_mask_without_torch():
    # roslaunch runs on the system Python, which need not have torch (here it lives in the venv):
    # the preset's action_mask must be read without it, or the managers silently get 'logic'.
    import subprocess
    import sys
    script = (
        "import sys, os\n"
        "class NoTorch:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'torch' or name.startswith('torch.'):\n"
        "            raise ImportError('no torch here')\n"
        "sys.meta_path.insert(0, NoTorch())\n"
        "import roslaunch\n"
        "config = roslaunch.config.load_config_default([(sys.argv[1], ['roslaunch', 'backend:=ros', "
        "'preset:=sequential'])], None, verbose=False)\n"
        "print(sorted(set(p.value for k, p in config.params.items() if k.endswith('/mask'))))\n")
    out = subprocess.run([sys.executable, "-c", script, os.path.join(REPO, "launch", "train.launch")],
                         capture_output=True, text=True, timeout=120,
                         env=dict(os.environ, PYTHONPATH=os.path.join(REPO, "src") + os.pathsep +
                                  os.environ.get("PYTHONPATH", "")))
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1] == "['finished']"
