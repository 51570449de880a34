"""robot_actor: one robot's trained actor at run time (decentralised execution, docs/guide/training.md).

Started in the robot's namespace (launch/execute.launch). Parameters: ~policy (actor file, or generalist),
~agent_index (this robot's index in the scenario's robot order), ~scenario (the scenario file:
a set actor reads its observation with the scenario's tasks and nominal travel times, which
every robot knows), ~lookahead (true: each choice looks ahead, evaluation/lookahead.py; a set actor
only; its budget in config/task_baselines.yaml, whose opening rollout plan the node makes at
start, in the background), ~hold_successors (the task manager's rule, which the
lookahead's model of the episode follows; empty: config/task.yaml's), ~precedence_margin (s the
episodes the lookahead keeps leave between a predecessor's finish and its successor's arrival in
one step; empty: config/task_baselines.yaml's). Subscribes only to this robot's task_observation (marl_mrta/RobotObservation) and publishes its choice on task_choice
(marl_mrta/TaskChoice); its GRU state is its own, reset at each episode_start. Sets
~action_mask, ~decision_order and ~turn_order to those its policy was trained with (rl_manager
checks them; a sequential policy is asked in turn, with the tasks claimed before it in `claimed`).
"""

import math
import threading

import rospy
import torch

from marl_mrta.baselines.settings import load_baseline_settings
from marl_mrta.common.config import ConfigError
from marl_mrta.evaluation.lookahead import Lookahead
from marl_mrta.mappo.policy import PolicyFileError, SetActorPolicy, actor_file_path, load_policy
from marl_mrta.model.scenario import ScenarioError, load_scenario
from marl_mrta.msg import RobotObservation, TaskChoice
from marl_mrta.evaluation.robot_actor import ObservationError, RobotActor


def precedence_margin(name: str, value, default: float) -> float:
    """~precedence_margin: s, finite and >= 0; empty: config/task_baselines.yaml's."""
    if str(value).strip() == "":
        return default
    try:
        margin = float(value)
    except (TypeError, ValueError):
        margin = math.nan
    if not (math.isfinite(margin) and margin >= 0.0):
        raise ValueError(f"{name}/precedence_margin: {value!r}: give seconds >= 0, or nothing")
    return margin


def main() -> int:
    rospy.init_node("robot_actor")
    name = rospy.get_name()
    if not rospy.has_param("~policy") or not rospy.has_param("~agent_index"):
        rospy.logfatal("%s/%s: missing: give the actor file (~policy) and this robot's index (~agent_index)",
                       name, "policy" if not rospy.has_param("~policy") else "agent_index")
        return 2
    torch.set_num_threads(1)   # one robot's small network, and its lookahead's many play-outs: faster on one thread
    try:
        policy = load_policy(rospy.get_param("~policy"))
        if isinstance(policy, SetActorPolicy):
            if not rospy.get_param("~scenario", ""):
                raise ValueError(f"{name}/scenario: missing: a set actor needs the scenario file")
            policy = policy.for_scenario(load_scenario(rospy.get_param("~scenario")))
        lookahead = None
        if rospy.get_param("~lookahead", False):
            hold = str(rospy.get_param("~hold_successors", "")).strip().lower()
            if hold not in ("", "true", "false"):
                raise ValueError(f"{name}/hold_successors: {hold!r}: give true, false or nothing")
            settings = load_baseline_settings()
            margin = precedence_margin(name, rospy.get_param("~precedence_margin", ""), settings.precedence_margin)
            lookahead = Lookahead(policy, settings.lookahead, None if not hold else hold == "true", margin)
        actor = RobotActor(policy, int(rospy.get_param("~agent_index")), lookahead)
    except (PolicyFileError, ObservationError, ScenarioError, ConfigError, ValueError) as error:
        rospy.logfatal("%s: %s", name, error)
        return 2
    rospy.set_param("~action_mask", actor.policy.action_mask)
    rospy.set_param("~decision_order", actor.policy.decision_order)
    rospy.set_param("~turn_order", actor.policy.turn_order)
    choices = rospy.Publisher("task_choice", TaskChoice, queue_size=10)
    tasks = [task.id for task in policy.view.scenario.tasks] if isinstance(policy, SetActorPolicy) else []

    def task_name(action: int) -> str:
        return tasks[action] if action < len(tasks) else "None"

    def on_observation(msg: RobotObservation) -> None:
        try:
            decision = actor.decide(msg.episode, msg.step, msg.episode_start, msg.obs, msg.action_mask,
                                    msg.agent_index, msg.claimed)
        except ObservationError as error:
            # Not answering makes rl_manager stop with a timeout naming this robot; say why here.
            rospy.logerr_throttle(5.0, "%s: episode %d step %d: %s" % (name, msg.episode, msg.step, error))
            return
        choices.publish(TaskChoice(episode=decision.episode, step=decision.step, action=decision.action))
        looked = actor.looked
        if looked is not None and not decision.repeated and msg.step == 0 and lookahead.budget.opening is not None:
            opening = lookahead.opening
            rospy.loginfo("%s: episode %d: %s", name, msg.episode, "no rollout plan to open with: the searches alone"
                          if opening is None else "the rollout plan to open with ends at %.2f s (made in %.1f s)"
                          % (opening.usable_makespan, lookahead.opening_s))
        if looked is not None and not decision.repeated and looked.action != looked.own:
            found = "kept" if looked.orientation < 0 else "found (orientation %d)" % looked.orientation
            rospy.loginfo("%s: episode %d step %d: %s instead of the actor's %s (the team's episode %s ends at "
                          "%.2f s; %d play-outs)", name, msg.episode, msg.step, task_name(looked.action),
                          task_name(looked.own), found, looked.makespan, looked.play_outs)

    rospy.Subscriber("task_observation", RobotObservation, on_observation, queue_size=10)
    if lookahead is not None:   # the opening plan, made while the task manager starts (the first step waits for it)
        threading.Thread(target=lookahead.prepare, name="opening", daemon=True).start()
    rospy.loginfo("%s: robot %d acting with %s%s", name, actor.agent_index, actor_file_path(rospy.get_param("~policy")),
                  "" if lookahead is None else ", " + lookahead.describe())
    rospy.spin()
    return 0
