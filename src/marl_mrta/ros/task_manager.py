"""rl_task_allocation_manager: the decision process of one arena on the ROS graph.

A thin shell: the scenario, task rules, reward and episode logic are the ROS-free
env.task_env.TaskEnvironment (decision_mode event: env.event_env.EventTaskEnvironment); this class
gives it an executor (`mode`: simulation, the RosExecutor; real, the RealExecutor of real robots
with ros/real_mode.py's services), and writes `~env` (the environment's sizes and settings) for
clients such as ros/env_client.py. Who decides (`allocator`): a client over `~reset` and `~step`,
or the manager itself with the replanning allocator (ros/live_episodes.py). Around it: the paper's
topics and the rviz markers (ros/manager_topics.py) and, in event mode, a live fleet's run-time
requests and status (ros/fleet_services.py). In event mode a step is a decision instant: robots
keep driving between steps.
"""
from __future__ import annotations

import threading
from dataclasses import replace
from typing import Optional, Sequence

import rospy

from marl_mrta.srv import TaskReset, TaskResetResponse, TaskStep, TaskStepResponse

from marl_mrta.baselines.settings import load_baseline_settings
from marl_mrta.env.api import StepOutput
from marl_mrta.env.factory import make_env, scenario_leg_timeouts
from marl_mrta.model.scenario import load_scenario
from marl_mrta.ros.conversions import to_message
from marl_mrta.ros.env_client import goal_timeout_parameters
from marl_mrta.ros.executor import RosExecutor
from marl_mrta.ros.fleet_requests import merged_output
from marl_mrta.ros.fleet_services import FleetServices
from marl_mrta.ros.live_episodes import ReplanEpisodes
from marl_mrta.ros.manager_settings import ManagerSettings
from marl_mrta.ros.manager_topics import ManagerTopics
from marl_mrta.ros.real_executor import RealExecutor
from marl_mrta.ros.real_mode import RealModeServices
from marl_mrta.ros.sim_clock import SimulatorLost

#: ~reset and ~step under allocator replan.
OWN_EPISODES = "allocator replan: the task manager runs its episodes itself; ~reset and ~step serve allocator client"


class TaskManagerNode:
    """Owns one TaskEnvironment over a RosExecutor or RealExecutor; services and topics around it."""

    def __init__(self, settings: ManagerSettings):
        self.settings = settings
        self.scenario = load_scenario(settings.scenario)
        # Each leg's goal timeout, from the scenario's travel table (planned once, as make_env's).
        timeouts = scenario_leg_timeouts(self.scenario, settings.task_config, settings.goal_timeout)
        self.real = settings.mode == "real"
        self.executor = (RealExecutor(self.scenario, settings.executor, settings.real, timeouts) if self.real
                         else RosExecutor(self.scenario, settings.executor, timeouts))
        self.real_services: Optional[RealModeServices] = None
        self.env = make_env(self.scenario, executor=self.executor, mask=settings.mask,
                            task_config=settings.task_config, reward_config=settings.reward_config,
                            hold_successors=settings.hold_successors, decision_mode=settings.decision_mode,
                            goal_timeout=settings.goal_timeout)
        self.scenario = self.env.scenario   # its episode timeout a number (an auto one computed)
        self.event = self.env.settings.decision_mode == "event"
        self.allocator = settings.live.allocator
        self.replan = load_baseline_settings().replan if self.allocator == "replan" else None
        self.robot_ns = self.executor.namespaces
        self._lock = threading.Lock()   # held while a reset or step runs
        self._episode_running = False
        self.topics = ManagerTopics(self.env, self.executor, settings.executor.map_frame, settings.marker_period,
                                    lambda: self.fleet.latest)
        self.fleet = FleetServices(self.env, self.executor, lambda: self._episode_running, self.allocator,
                                   settings.live.request_wait, on_change=self.topics.publish_markers,
                                   on_robot_fault=self._robot_lost)

    def start(self) -> None:
        """Waits for the graph, puts the robots on their start poses (allocator client; with replan
        its first episode does), then serves."""
        self.executor.wait_for_graph()
        if self.real:   # real robots drive to their start and wait for the operator at each reset
            self.real_services = RealModeServices(self.executor, self.scenario, self._lock, self._partial_record,
                                                  self.settings.real.aborted_episode_file)
        elif self.allocator == "client":
            with self.executor.start_up_limits():
                self.env.reset()
        env = self.env
        rospy.set_param("~env", {"mode": self.settings.mode, "allocator": self.allocator,
            "scenario": str(self.scenario.source.resolve()), "robots": self.robot_ns,
            "n_agents": env.n_agents, "n_actions": env.n_actions, "obs_dim": env.obs_dim,
            "state_dim": env.state_dim, "mask": env.settings.mask, "min_step": env.settings.min_step,
            "hold_successors": env.settings.hold_successors, "decision_mode": env.settings.decision_mode,
            **goal_timeout_parameters(env)})
        rospy.Service("~reset", TaskReset, self._on_reset)
        rospy.Service("~step", TaskStep, self._on_step)
        self.topics.start()
        self.fleet.changed(force=True)
        rospy.loginfo("rl_task_allocation_manager: scenario %s (%s), %d robots, %d tasks, mask %s%s, allocator %s: ready",
                      self.scenario.name, self.scenario.source, self.scenario.n_robots, self.scenario.n_tasks,
                      env.settings.mask, ", event mode" if self.event else "", self.allocator)
        if self.allocator == "replan":
            ReplanEpisodes(self, self.settings.live, self.replan).start()

    # ------------------------------------------------------------------ episodes (both allocators)

    def reset_episode(self, seed: Optional[int]) -> StepOutput:
        """A new episode (robots on their start poses; real: driven there, then the operator's go)."""
        with self._lock:
            self._episode_running = False
            output = self.env.reset(seed)
            self._episode_running = True
            self.topics.episode_started()
            self.fleet.episode_started()
            if self.real_services is not None:
                self.real_services.episode_started()
            rospy.loginfo("episode reset (seed %s): robots on their start poses", "-" if seed is None else seed)
            return output

    def step_episode(self, actions: Sequence[int]) -> StepOutput:
        """One decision instant; the requests that ended it, or wait, applied before it returns."""
        with self._lock:
            goals = [None if a == self.env.n_tasks else int(a) for a in actions]
            self.topics.before_step(goals)
            try:
                output = self.env.step(actions)
            finally:
                self.topics.step_ended()
            over = output.done or output.truncated
            if over:
                self._episode_running = False
            if self.event:   # requests that ended the transition or wait (after the end: refused)
                applied = self.fleet.apply_waiting()
                if applied is not None and not over:
                    output = merged_output(output, applied)
            self.fleet.changed()
            self.topics.after_step(output)
            if over:
                self._log_end(output)
                if self.real_services is not None and output.info.abort_reason:
                    self.real_services.write_aborted(output.info.episode)
            return output

    def _partial_record(self):
        """The running episode's record so far (real mode's shutdown stop), None between episodes."""
        if not self._episode_running or self.env.record is None or self.env.over:
            return None
        return replace(self.env.record, makespan=self.env.elapsed)

    def _robot_lost(self, robot: int, reason: str) -> None:
        """A robot the executor stopped alone (on_robot_fault continue): real mode writes it down."""
        if self.real_services is not None:
            record = self._partial_record()
            if record is not None:
                self.real_services.write_robot_fault(record, self.robot_ns[robot], reason)

    # ------------------------------------------------------------------ services (allocator client)

    def _on_reset(self, request) -> TaskResetResponse:
        if self.allocator != "client":
            raise rospy.ServiceException(OWN_EPISODES)
        try:
            output = self.reset_episode(None if request.seed < 0 else int(request.seed))
        except SimulatorLost as lost:
            rospy.logerr("reset failed: %s", lost)
            raise rospy.ServiceException(f"reset failed: {lost}") from None
        return TaskResetResponse(output=to_message(output))

    def _on_step(self, request) -> TaskStepResponse:
        if self.allocator != "client":
            raise rospy.ServiceException(OWN_EPISODES)
        actions = list(request.actions)
        problem = self._check_actions(actions)
        if problem:
            rospy.logerr("step refused: %s", problem)
            raise rospy.ServiceException(problem)
        return TaskStepResponse(output=to_message(self.step_episode(actions)))

    def _check_actions(self, actions: Sequence[int]) -> str:
        if not self._episode_running:
            return "no episode running: call reset first"
        n_robots, n_tasks = self.scenario.n_robots, self.env.n_tasks
        if len(actions) != n_robots:
            return f"actions: expected {n_robots} values, got {len(actions)}"
        bad = [a for a in actions if not 0 <= a <= n_tasks]
        return f"actions: {bad} outside 0..{n_tasks} ({n_tasks} = None)" if bad else ""

    @staticmethod
    def _log_end(output: StepOutput) -> None:
        record = output.info.episode
        if output.info.abort_reason:
            rospy.logerr("episode aborted at %.1f s after %d steps: %s", record.makespan,
                         record.decision_steps, output.info.abort_reason)
        else:
            rospy.loginfo("episode %s: makespan %.2f s, %d steps, %s", "complete" if output.done else "timed out",
                          record.makespan, record.decision_steps,
                          "logic-consistent" if record.logic_consistent else "not logic-consistent")
