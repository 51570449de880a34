"""The orchestrator's side of decentralised execution on the ROS graph: /<robot>/task_observation
out, /<robot>/task_choice in (marl_mrta/RobotObservation, marl_mrta/TaskChoice), and the check
that every robot's actor was trained for the manager's masks. The board and the policy they
feed are ROS-free (evaluation/decentralised.py)."""
from __future__ import annotations

import time
from typing import Sequence, Tuple

import rospy

from marl_mrta.msg import RobotObservation, TaskChoice

from marl_mrta.evaluation.decentralised import (ACTOR_NODE, CHOICE_TOPIC, OBSERVATION_TOPIC, ActorTimeout, ChoiceBoard,
                                                ObservationRow)


class RosActorLinks:
    """Publishers of /<robot>/task_observation and subscribers of /<robot>/task_choice."""

    def __init__(self, namespaces: Sequence[str], board: ChoiceBoard):
        self.namespaces = ["/" + ns.strip("/") for ns in namespaces]
        self.publishers = [rospy.Publisher(ns + "/" + OBSERVATION_TOPIC, RobotObservation, queue_size=10)
                           for ns in self.namespaces]
        self.subscribers = [rospy.Subscriber(ns + "/" + CHOICE_TOPIC, TaskChoice,
                                             lambda m, i=i: board.offer(i, m.episode, m.step, m.action), queue_size=10)
                            for i, ns in enumerate(self.namespaces)]

    def send(self, robot_index: int, row: ObservationRow) -> None:
        self.publishers[robot_index].publish(RobotObservation(
            episode=row.episode, step=row.step, episode_start=row.episode_start, obs=row.obs.tolist(),
            action_mask=row.action_mask.tobytes(), agent_index=row.agent_index, claimed=row.claimed.tobytes()))

    def wait_connected(self, timeout: float) -> None:
        """Until every robot's actor listens and answers on its topics (both directions)."""
        deadline = time.monotonic() + timeout
        while not rospy.is_shutdown():
            missing = [ns for ns, pub, sub in zip(self.namespaces, self.publishers, self.subscribers)
                       if pub.get_num_connections() < 1 or sub.get_num_connections() < 1]
            if not missing:
                return
            if time.monotonic() > deadline:
                raise ActorTimeout(f"{', '.join(missing)}: no {ACTOR_NODE} connected to {OBSERVATION_TOPIC} and "
                                   f"{CHOICE_TOPIC} after {timeout:g} s (launch/execute.launch starts one per robot)")
            time.sleep(0.1)
        raise ActorTimeout("shutdown while waiting for the robots' actors")


def check_actor_masks(namespaces: Sequence[str], env_mask: str) -> Tuple[str, str]:
    """Each actor node states the action-mask mode (~action_mask), decision order
    (~decision_order) and turn order (~turn_order) its policy was trained with; acting under
    another mask would feed it inputs it never saw. Returns the robots' common decision order
    and turn order: the robots must agree on who answers when."""
    settings = {"decision_order": set(), "turn_order": set()}
    for ns in namespaces:
        node = "/" + ns.strip("/") + "/" + ACTOR_NODE
        trained = rospy.get_param(node + "/action_mask", None)
        if trained is not None and trained != env_mask:
            raise ValueError(f"{node}/action_mask: the policy was trained with mask "
                             f"{trained}, the task manager runs mask {env_mask} (set mask:={trained})")
        settings["decision_order"].add(rospy.get_param(node + "/decision_order", "simultaneous"))
        settings["turn_order"].add(rospy.get_param(node + "/turn_order", "index"))
    for key, values in settings.items():
        if len(values) > 1:
            raise ValueError(f"{ACTOR_NODE}/{key}: the robots' policies disagree ({', '.join(sorted(values))}); "
                             f"give every robot the same policy")
    return (settings["decision_order"].pop() if settings["decision_order"] else "simultaneous",
            settings["turn_order"].pop() if settings["turn_order"] else "index")
