"""ROS node: the task manager of one arena (scenario, precedence, goals, reward, episodes).

Topics, services and parameters: docs/reference/nodes_tasks.md. Bad parameters or
scenario, or a graph that does not come up: one FATAL line and exit status 1.
"""

import rospy

from marl_mrta.ros.manager_settings import read_manager_settings
from marl_mrta.ros.sim_clock import SimulatorLost
from marl_mrta.ros.task_manager import TaskManagerNode
from marl_mrta.model.scenario import ScenarioError
from marl_mrta.common.config import ConfigError


def main() -> int:
    rospy.init_node("rl_task_allocation_manager")
    name = rospy.get_name()
    try:
        settings = read_manager_settings(rospy.get_param("~", {}), name)
        node = TaskManagerNode(settings)
        node.start()
    except (ScenarioError, ConfigError) as error:
        rospy.logfatal("%s", error)
        return 1
    except SimulatorLost as lost:
        rospy.logfatal("%s: the graph did not come up: %s", name, lost)
        return 1
    rospy.spin()
    return 0
