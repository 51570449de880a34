"""launch/real.launch, read without starting anything: which episodes node each method gets, and
what it is handed (the rollout its actor file, which the planners do not take); and `reference`
and `goal_timeout` of the launch files that run episodes (the latter down to every task manager)."""
import os

import pytest

roslaunch = pytest.importorskip("roslaunch")

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.fixture(autouse=True)
def package_path(monkeypatch):
    """$(find marl_mrta) resolves to this checkout even without a sourced workspace."""
    monkeypatch.setenv("ROS_PACKAGE_PATH", REPO + os.pathsep + os.environ.get("ROS_PACKAGE_PATH", ""))


def episodes_node(*args):
    config = roslaunch.config.load_config_default(
        [(os.path.join(REPO, "launch", "real.launch"), ["roslaunch", "nav:=builtin", *args])], None, verbose=False)
    nodes = {n.namespace + n.name: n for n in config.nodes}
    actors = [name for name, node in nodes.items() if node.type == "robot_actor"]
    runner = nodes.get("/evaluate") or nodes["/rl_manager"]
    return runner, runner.args.split(), actors


@pytest.mark.parametrize("method", ["rollout", "exact,rollout,ga"])
def test_the_rollout_plans_from_the_actor_it_is_given_with_the_margin(method):
    runner, args, actors = episodes_node("method:=" + method, "policy:=generalist", "precedence_margin:=1.5")
    assert runner.type == "evaluate" and actors == []   # a plan: no actor node on the robots
    assert args[args.index("--method") + 1] == method
    assert args[args.index("--policy") + 1] == "generalist"
    assert args[args.index("--precedence-margin") + 1] == "1.5"


def test_the_planners_get_no_actor_file():
    runner, args, actors = episodes_node("method:=exact", "policy:=generalist")
    assert runner.type == "evaluate" and "--policy" not in args and actors == []


def test_a_policy_runs_on_the_robots_actor_nodes():
    runner, args, actors = episodes_node("method:=policy", "policy:=generalist")
    assert runner.type == "rl_manager" and args[0] == "execute"
    assert sorted(actors) == ["/tb3_0/robot_actor", "/tb3_1/robot_actor"]


def test_a_set_actors_nodes_get_the_scenario_and_the_generalist_its_mask():
    """Before, a set actor (the generalist, or one fine-tuned from it) on real.launch's actor nodes
    stopped the launch: "scenario: missing: a set actor needs the scenario file"."""
    scenario = os.path.join(REPO, "scenarios", "lab_2r.xml")
    config = roslaunch.config.load_config_default(
        [(os.path.join(REPO, "launch", "real.launch"),
          ["roslaunch", "nav:=builtin", "method:=policy", "policy:=generalist", "scenario:=" + scenario])],
        None, verbose=False)
    for robot in ("tb3_0", "tb3_1"):
        assert config.params[f"/{robot}/robot_actor/scenario"].value == scenario
    assert config.params["/rl_task_allocation_manager/mask"].value == "finished"
    config = roslaunch.config.load_config_default(
        [(os.path.join(REPO, "launch", "real.launch"),
          ["roslaunch", "nav:=builtin", "method:=policy", "policy:=/tmp/actor.pt"])], None, verbose=False)
    assert config.params["/rl_task_allocation_manager/mask"].value == "logic"   # the tuned preset's


def params_of(launch_file, *args):
    return roslaunch.config.load_config_default(
        [(os.path.join(REPO, "launch", launch_file), ["roslaunch", "nav:=builtin", *args])], None, verbose=False).params


@pytest.mark.slow
def test_lookahead_reaches_every_actor_node_with_the_managers_hold_and_a_longer_choice_wait():
    """real.launch lookahead:=true: each robot's actor looks ahead under the rule the task manager
    runs (real robots hold a successor reached early) and the plans' precedence margin;
    execute.launch and evaluate.launch too."""
    params = params_of("real.launch", "method:=policy", "policy:=generalist", "lookahead:=true")
    for robot in ("tb3_0", "tb3_1"):
        assert params[f"/{robot}/robot_actor/lookahead"].value is True
        assert params[f"/{robot}/robot_actor/hold_successors"].value is True
    runner, args, _ = episodes_node("method:=policy", "policy:=generalist", "lookahead:=true")
    assert args[args.index("--choice-timeout") + 1] == "300"     # 120 s + 90 s per robot: the openings first
    runner, args, _ = episodes_node("method:=policy", "policy:=generalist")
    assert args[args.index("--choice-timeout") + 1] == "30"
    assert params_of("real.launch", "method:=policy", "policy:=generalist")["/tb3_0/robot_actor/lookahead"].value is False
    lab_3r = os.path.join(REPO, "scenarios", "lab_3r.xml")
    params = params_of("evaluate.launch", "method:=lookahead", "policy:=generalist", "scenario:=" + lab_3r)
    assert [params[f"/tb3_{i}/robot_actor/lookahead"].value for i in range(3)] == [True] * 3
    assert params["/rl_task_allocation_manager/mask"].value == "finished"
    # the precedence margin of the plans reaches every robot's lookahead too
    params = params_of("evaluate.launch", "method:=lookahead", "policy:=generalist", "scenario:=" + lab_3r,
                       "precedence_margin:=1.0")
    assert [params[f"/tb3_{i}/robot_actor/precedence_margin"].value for i in range(3)] == [1.0] * 3
    params = params_of("real.launch", "method:=policy", "policy:=generalist", "lookahead:=true", "precedence_margin:=0.5")
    assert [params[f"/tb3_{i}/robot_actor/precedence_margin"].value for i in range(2)] == [0.5] * 2


@pytest.mark.parametrize("method", ["rollout", "policy", "exact,rollout"])
def test_an_actor_method_without_an_actor_stops_the_launch_before_it_starts_anything(method):
    """Before, method:=policy without policy:= started the robots' side and waited five minutes
    for actor nodes that were never started."""
    with pytest.raises(Exception) as error:
        episodes_node("method:=" + method)
    assert "policy:='': method:=" in str(error.value) and "\n" not in str(error.value).strip()


def manager_hold_successors(*args):
    config = roslaunch.config.load_config_default(
        [(os.path.join(REPO, "launch", "real.launch"), ["roslaunch", "nav:=builtin", *args])], None, verbose=False)
    return config.params["/rl_task_allocation_manager/hold_successors"].value


def test_real_robots_hold_a_successor_reached_early_unless_told_not_to():
    """The hold keeps the order, so plans need no margin by default (the step rules' optimum)."""
    assert manager_hold_successors() is True
    _, args, _ = episodes_node("method:=exact")
    assert args[args.index("--precedence-margin") + 1] == "0.0"
    assert manager_hold_successors("hold_successors:=false") is False


def navigation_outputs(*args):
    """Per robot: the topic its move_base publishes velocity commands on, and its cmd_vel_gate node."""
    config = roslaunch.config.load_config_default(
        [(os.path.join(REPO, "launch", "real.launch"), ["roslaunch", "nav:=builtin", *args])], None, verbose=False)
    nodes = {n.namespace + n.name: n for n in config.nodes}
    out = {}
    for robot in ("tb3_0", "tb3_1"):
        remaps = dict(nodes[f"/{robot}/move_base"].remap_args)
        out[robot] = (remaps.get("cmd_vel"), nodes.get(f"/{robot}/cmd_vel_gate"))
    return out, config.params


def test_move_base_drives_each_robot_through_its_gate_unless_told_not_to():
    outputs, params = navigation_outputs()
    for robot, (topic, gate) in outputs.items():
        assert topic == "cmd_vel_nav"
        assert gate is not None and gate.type == "cmd_vel_gate"
        # Its own permit: a stop of this robot alone (on_robot_fault continue) closes only its gate.
        assert params[f"/{robot}/cmd_vel_gate/permit_topic"].value == f"/rl_task_allocation_manager/drive_permit/{robot}"
    outputs, _ = navigation_outputs("cmd_vel_gate:=false")
    assert all(topic == "cmd_vel" and gate is None for topic, gate in outputs.values())


@pytest.mark.parametrize("launch_file, args, runner_name", [
    ("real.launch", ["nav:=builtin", "method:=policy", "policy:=generalist"], "/rl_manager"),
    ("real.launch", ["nav:=builtin", "method:=ga"], "/evaluate"),
    ("execute.launch", ["policy:=generalist"], "/rl_manager"),
    ("evaluate.launch", ["method:=policy", "policy:=generalist"], "/rl_manager"),
    ("evaluate.launch", ["method:=ga,auction"], "/evaluate")])
def test_reference_false_leaves_the_exact_reference_out(launch_file, args, runner_name):
    """The reference only gives the ratio column, and its search can take minutes on a large team."""
    def runner_args(*extra):
        config = roslaunch.config.load_config_default(
            [(os.path.join(REPO, "launch", launch_file), ["roslaunch", *args, *extra])], None, verbose=False)
        return {n.namespace + n.name: n for n in config.nodes}[runner_name].args.split()

    assert "--no-exact" not in runner_args()
    assert "--no-exact" in runner_args("reference:=false")


def goal_timeout_seen(launch_file, args, manager):
    """The manager's ~goal_timeout and the episodes command's --goal-timeout (None: none)."""
    config = roslaunch.config.load_config_default(
        [(os.path.join(REPO, "launch", launch_file), ["roslaunch", *args])], None, verbose=False)
    nodes = {n.namespace + n.name: n for n in config.nodes}
    command = nodes["/evaluate"].args.split() if "/evaluate" in nodes else []
    option = command[command.index("--goal-timeout") + 1] if "--goal-timeout" in command else None
    return config.params[manager + "/goal_timeout"].value, option


def test_the_goal_timeout_reaches_the_task_manager():
    """goal_timeout:= reaches the manager's ~goal_timeout as a string ("": the scenario's, else
    config/task.yaml's), and the episodes command that plans checks it against the manager's."""
    manager = "/rl_task_allocation_manager"
    assert goal_timeout_seen("task_manager.launch", [], manager) == ("", None)
    assert goal_timeout_seen("task_manager.launch", ["goal_timeout:=auto"], manager) == ("auto", None)
    assert goal_timeout_seen("real.launch", ["nav:=builtin", "method:=exact"], manager) == ("", None)
    assert goal_timeout_seen("real.launch", ["nav:=builtin", "method:=exact", "goal_timeout:=90"], manager) == \
        ("90", "90")


@pytest.mark.slow
@pytest.mark.parametrize("launch_file, args, manager, option", [
    ("tasks.launch", [], "/rl_task_allocation_manager", None),
    ("tasks.launch", ["arenas:=2"], "/arena_1/rl_task_allocation_manager", None),
    ("evaluate.launch", ["method:=exact"], "/rl_task_allocation_manager", "auto"),
    ("evaluate.launch", ["method:=policy", "policy:=generalist"], "/rl_task_allocation_manager", None),
    ("execute.launch", ["policy:=generalist"], "/rl_task_allocation_manager", None),
    ("train.launch", ["backend:=ros"], "/arena_0/rl_task_allocation_manager", None)])
def test_the_simulations_launch_files_give_the_goal_timeout_to_every_manager(launch_file, args, manager, option):
    assert goal_timeout_seen(launch_file, args + ["goal_timeout:=auto"], manager) == ("auto", option)


def test_the_goal_timeout_of_training_reaches_the_trainer():
    def trainer(*extra):
        config = roslaunch.config.load_config_default(
            [(os.path.join(REPO, "launch", "train.launch"), ["roslaunch", *extra])], None, verbose=False)
        return {n.namespace + n.name: n for n in config.nodes}["/rl_manager"].args.split()

    assert "--goal-timeout" not in trainer()
    command = trainer("goal_timeout:=auto")
    assert command[command.index("--goal-timeout") + 1] == "auto"
