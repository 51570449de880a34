"""RosTaskEnvClient: env.api.TaskAllocationEnv over a running task manager's services.

The learner, the baselines and the evaluation talk to it exactly as to an embedded
environment: reset(seed) and step(actions) return StepOutputs (conversions.from_message),
episode records included, and in event mode which robots decide (StepOutput.deciding) and the
tasks the others are busy with (StepInfo.robot_tasks). The manager's `~env` parameter gives the
sizes and settings, its decision mode included (settings.decision_mode), and the goal timeout
and episode timeout its episodes run with (the client's scenario carries them as make_env's does).
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

import rospy

from marl_mrta.srv import TaskReset, TaskStep

from marl_mrta.env.api import StepOutput
from marl_mrta.env.settings import TaskSettings
from marl_mrta.model.goal_timeout import GoalTimeout, parse_timeout
from marl_mrta.model.scenario import Scenario, load_scenario
from marl_mrta.ros.conversions import from_message
from marl_mrta.ros.sim_clock import SimulatorLost

DEFAULT_MANAGER = "/rl_task_allocation_manager"


def arena_managers(arenas: int) -> List[str]:
    """The task managers of a simulator with `arenas` arenas (launch/tasks.launch arenas:=K)."""
    if arenas == 1:
        return [DEFAULT_MANAGER]
    return [f"/arena_{k}{DEFAULT_MANAGER}" for k in range(arenas)]


def goal_timeout_parameters(env) -> Dict[str, Any]:
    """The manager's `~env` entries of an environment's timeouts: its goal timeout rule (seconds
    or 'auto', factor, margin) and its episode timeout (a number, an auto one computed)."""
    rule = env.settings.goal_timeout
    return {"goal_timeout": rule.value, "goal_timeout_factor": rule.factor, "goal_timeout_margin": rule.margin,
            "episode_timeout": env.scenario.episode_timeout}


def goal_timeout_of(env: Dict[str, Any]) -> GoalTimeout:
    """The goal timeout rule of a manager's `~env` (goal_timeout_parameters)."""
    value = parse_timeout(env["goal_timeout"])
    return GoalTimeout(None if isinstance(value, str) else value, float(env["goal_timeout_factor"]),
                       float(env["goal_timeout_margin"]))


class ManagerUnavailable(RuntimeError):
    """The task manager is not there or failed a call; str(error) is one line."""


class RosTaskEnvClient:
    """A task-allocation environment whose robots are those of a running rl_task_allocation_manager."""

    def __init__(self, manager: str = DEFAULT_MANAGER, wait_wall: float = 120.0):
        self.manager = manager.rstrip("/")
        if not rospy.core.is_initialized():
            rospy.init_node("task_env_client", anonymous=True, disable_signals=True)
        self._reset = rospy.ServiceProxy(self.manager + "/reset", TaskReset)
        self._step = rospy.ServiceProxy(self.manager + "/step", TaskStep)
        try:
            self._reset.wait_for_service(timeout=wait_wall)
            self._step.wait_for_service(timeout=wait_wall)
        except rospy.ROSException:
            raise ManagerUnavailable(f"{self.manager}: services reset/step not available after {wait_wall:.0f} s "
                                     f"(is the task manager running? roslaunch marl_mrta tasks.launch)") from None
        env = rospy.get_param(self.manager + "/env")
        goal_timeout = goal_timeout_of(env)
        # As the manager's environment has it: the episode timeout a number, the goal timeout in force.
        self.scenario: Scenario = dataclasses.replace(load_scenario(env["scenario"]),
                                                      episode_timeout=float(env["episode_timeout"]),
                                                      goal_timeout=goal_timeout.value)
        self.settings = TaskSettings(mask=env["mask"], min_step=float(env["min_step"]),
                                     goal_timeout=goal_timeout,
                                     hold_successors=bool(env.get("hold_successors", False)),
                                     decision_mode=str(env.get("decision_mode", "synchronous")))
        self.n_agents = int(env["n_agents"])
        self.n_tasks = self.scenario.n_tasks
        self.n_actions = int(env["n_actions"])
        self.obs_dim = int(env["obs_dim"])
        self.state_dim = int(env["state_dim"])
        self.mode = str(env.get("mode", "simulation"))   # simulation | real (real robots or the stand-in)

    @property
    def noise_profile(self) -> str:
        """The simulator's noise profile (what the episodes ran under; the simulator node is /simulator);
        `real` for real robots."""
        if self.mode == "real":
            return "real"
        return str(rospy.get_param("/simulator/noise_profile", "unknown"))

    @property
    def stops_on_abort(self) -> bool:
        """Real robots: an aborted episode is a safety stop, after which no episode starts by itself."""
        return self.mode == "real"

    @property
    def scenario_path(self) -> Path:
        return Path(self.scenario.source).resolve()

    def reset(self, seed: Optional[int] = None) -> StepOutput:
        return self._call(self._reset, -1 if seed is None else int(seed), "reset")

    def step(self, actions: Sequence[int]) -> StepOutput:
        return self._call(self._step, [int(a) for a in actions], "step")

    def _call(self, proxy, argument, what: str) -> StepOutput:
        try:
            response = proxy(argument)
        except (rospy.ServiceException, SimulatorLost) as error:
            raise ManagerUnavailable(f"{self.manager}/{what}: {str(error).splitlines()[0]}") from None
        return from_message(response.output)
