"""rl_task_allocation_manager: the decision process of one arena on the ROS graph.

A thin shell: the scenario, task rules, reward and episode logic are the ROS-free
env.task_env.TaskEnvironment (decision_mode event: env.event_env.EventTaskEnvironment); this class
gives it an executor (`mode`: simulation, the RosExecutor; real, the RealExecutor of real robots
with ros/real_mode.py's services), serves `~reset` and `~step`, publishes the paper's topics and the
rviz markers, and writes `~env` (the environment's sizes and settings) for clients such as
ros/env_client.py. In event mode a step is a decision instant: the topics follow the events (a
robot's goal when it is sent, a reach when a task is finished), and robots keep driving between
steps.
"""
from __future__ import annotations

import threading
from dataclasses import replace
from typing import List, Optional, Sequence

import rospy
from geometry_msgs.msg import PoseStamped
from visualization_msgs.msg import MarkerArray

from marl_mrta.msg import IdleTime, TaskAssignment, TaskReached
from marl_mrta.srv import TaskReset, TaskResetResponse, TaskStep, TaskStepResponse

from marl_mrta.env.api import StepOutput
from marl_mrta.env.factory import make_env, scenario_leg_timeouts
from marl_mrta.model.scenario import load_scenario
from marl_mrta.ros.conversions import to_message
from marl_mrta.ros.env_client import goal_timeout_parameters
from marl_mrta.ros.executor import RosExecutor
from marl_mrta.ros.manager_settings import ManagerSettings
from marl_mrta.ros.markers import task_markers
from marl_mrta.ros.move_base_link import yaw_to_quaternion
from marl_mrta.ros.real_executor import RealExecutor
from marl_mrta.ros.real_mode import RealModeServices
from marl_mrta.ros.sim_clock import SimulatorLost


class TaskManagerNode:
    """Owns one TaskEnvironment over a RosExecutor; services and topics around it."""

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
        if self.event:   # goals go out one by one, as the executor sends them
            self.executor.goal_listener = self._on_goal_sent
        self._deciding: List[bool] = [True] * self.scenario.n_robots   # event mode: of the last output
        self._entries_seen = 0   # event mode: the record's entries published so far
        self.robot_ns = self.executor.namespaces
        self._lock = threading.Lock()
        self._episode_running = False
        self._driving = threading.Event()
        self._marker_lock = threading.Lock()
        self._assigned: List[Optional[int]] = [None] * self.scenario.n_robots
        self.pub_assigned = rospy.Publisher("Global_assigned_task", TaskAssignment, queue_size=10, latch=True)
        self.pub_reached = rospy.Publisher("Global_reached_task", TaskReached, queue_size=50)
        self.pub_idle = rospy.Publisher("idle_time", IdleTime, queue_size=10)
        self.pub_goal = [rospy.Publisher("/" + ns + "/goal", PoseStamped, queue_size=1, latch=True) for ns in self.robot_ns]
        self.pub_markers = rospy.Publisher("task_markers", MarkerArray, queue_size=1, latch=True)

    def start(self) -> None:
        """Waits for the graph, puts the robots on their start poses, then serves."""
        self.executor.wait_for_graph()
        if self.real:   # real robots drive to their start and wait for the operator at each reset
            self.real_services = RealModeServices(self.executor, self.scenario, self._lock, self._partial_record,
                                                  self.settings.real.aborted_episode_file)
        else:
            with self.executor.start_up_limits():
                self.env.reset()
        env = self.env
        rospy.set_param("~env", {"mode": self.settings.mode,
            "scenario": str(self.scenario.source.resolve()), "robots": self.robot_ns,
            "n_agents": env.n_agents, "n_actions": env.n_actions, "obs_dim": env.obs_dim,
            "state_dim": env.state_dim, "mask": env.settings.mask, "min_step": env.settings.min_step,
            "hold_successors": env.settings.hold_successors, "decision_mode": env.settings.decision_mode,
            **goal_timeout_parameters(env)})
        rospy.Service("~reset", TaskReset, self._on_reset)
        rospy.Service("~step", TaskStep, self._on_step)
        self._publish_markers()
        if self.settings.marker_period > 0.0:
            threading.Thread(target=self._refresh_markers, daemon=True, name="markers").start()
        rospy.loginfo("rl_task_allocation_manager: scenario %s (%s), %d robots, %d tasks, mask %s%s: ready",
                      self.scenario.name, self.scenario.source, self.scenario.n_robots, self.scenario.n_tasks,
                      env.settings.mask, ", event mode" if self.event else "")

    # ------------------------------------------------------------------ services

    def _on_reset(self, request) -> TaskResetResponse:
        with self._lock:
            self._episode_running = False
            self._assigned = [None] * self.scenario.n_robots
            try:
                output = self.env.reset(None if request.seed < 0 else int(request.seed))
            except SimulatorLost as lost:
                rospy.logerr("reset failed: %s", lost)
                raise rospy.ServiceException(f"reset failed: {lost}") from None
            self._episode_running = True
            self._deciding = self._deciding_of(output)
            self._entries_seen = 0
            self._publish_markers()
            rospy.loginfo("episode reset (seed %d): robots on their start poses", request.seed)
            return TaskResetResponse(output=to_message(output))

    def _on_step(self, request) -> TaskStepResponse:
        with self._lock:
            actions = list(request.actions)
            problem = self._check_actions(actions)
            if problem:
                rospy.logerr("step refused: %s", problem)
                raise rospy.ServiceException(problem)
            goals = [None if a == self.scenario.n_tasks else int(a) for a in actions]
            if self.event:   # only the deciding robots' actions count
                goals = [g if deciding else None for g, deciding in zip(goals, self._deciding)]
            self._publish_assignment(goals)
            self._driving.set()
            try:
                output = self.env.step(actions)
            finally:
                with self._marker_lock:
                    self._driving.clear()
            self._publish_results(output)
            self._deciding = self._deciding_of(output)
            if output.done or output.truncated:
                self._episode_running = False
                self._log_end(output)
                if self.real_services is not None and output.info.abort_reason:
                    self.real_services.write_aborted(output.info.episode)
            return TaskStepResponse(output=to_message(output))

    def _partial_record(self):
        """The running episode's record so far (real mode's shutdown stop), None between episodes."""
        if not self._episode_running or self.env.record is None or self.env.over:
            return None
        return replace(self.env.record, makespan=self.env.elapsed)

    def _check_actions(self, actions: Sequence[int]) -> str:
        if not self._episode_running:
            return "no episode running: call reset first"
        if len(actions) != self.scenario.n_robots:
            return f"actions: expected {self.scenario.n_robots} values, got {len(actions)}"
        bad = [a for a in actions if not 0 <= a <= self.scenario.n_tasks]
        return f"actions: {bad} outside 0..{self.scenario.n_tasks} ({self.scenario.n_tasks} = None)" if bad else ""

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

    # ------------------------------------------------------------------ topics

    def _publish_assignment(self, goals: Sequence[Optional[int]]) -> None:
        now = rospy.Time.now()
        tasks = self.scenario.tasks
        self._assigned = list(goals)
        self.pub_assigned.publish(TaskAssignment(stamp=now, step=self.env.step_index, robots=self.robot_ns,
                                                 tasks=[tasks[g].id if g is not None else "" for g in goals]))
        if self.event:   # robots that drive on keep their tasks; goals go out as they are sent
            self._assigned = [g if deciding else busy
                              for g, deciding, busy in zip(goals, self._deciding, self._robot_tasks())]
            self._publish_markers()
            return
        for publisher, goal in zip(self.pub_goal, goals):
            if goal is None:
                continue
            self._publish_goal(publisher, goal, now)
        self._publish_markers()

    def _publish_goal(self, publisher, task: int, stamp) -> None:
        msg = PoseStamped()
        msg.header.stamp, msg.header.frame_id = stamp, self.settings.executor.map_frame
        pose = self.scenario.tasks[task].goal
        msg.pose.position.x, msg.pose.position.y = pose.x, pose.y
        o = msg.pose.orientation
        o.x, o.y, o.z, o.w = yaw_to_quaternion(pose.yaw)
        publisher.publish(msg)

    def _on_goal_sent(self, robot: int, task: int) -> None:
        """Event mode: the executor sent the robot its goal (and move_base took it)."""
        self._publish_goal(self.pub_goal[robot], task, rospy.Time.now())

    def _publish_results(self, output: StepOutput) -> None:
        if self.event:
            self._publish_events(output)
            return
        now = rospy.Time.now()
        info = output.info
        for i, (task, order) in enumerate(zip(info.finished_task, info.finish_order)):
            if task is None:
                continue
            self.pub_reached.publish(TaskReached(stamp=now, robot=self.robot_ns[i], task=self.scenario.tasks[task].id,
                                                 order=int(order), logic_correct=bool(info.correct_order[i])))
        self.pub_idle.publish(IdleTime(stamp=now, step=int(info.step), robots=self.robot_ns,
                                       idle_time=[float(t) for t in info.idle_time]))
        if self.env.settings.hold_successors:   # why a robot stood at its task
            for i, goal in enumerate(self._assigned):
                if goal is not None and info.reached[i] and not info.finished[goal]:
                    rospy.loginfo("%s at %s: a predecessor is not finished; the task stays open", self.robot_ns[i],
                                  self.scenario.tasks[goal].id)
                elif info.held_time[i] > 0.0:
                    rospy.loginfo("%s waited %.2f s at %s for its predecessors", self.robot_ns[i], info.held_time[i],
                                  self.scenario.tasks[goal].id)
        self._assigned = [None] * self.scenario.n_robots
        self._publish_markers()

    def _publish_events(self, output: StepOutput) -> None:
        """Event mode: each task finished since the last step (its order from the record), the
        transition's idle time, and the markers with the tasks robots still drive to or stand at."""
        now = rospy.Time.now()
        info = output.info
        record = self.env.record
        for entry in record.entries[self._entries_seen:]:
            if entry.finished:
                self.pub_reached.publish(TaskReached(stamp=now, robot=self.robot_ns[entry.robot],
                                                     task=self.scenario.tasks[entry.task].id, order=int(entry.order),
                                                     logic_correct=bool(entry.logic_correct)))
                if entry.service_start is not None and entry.reach is not None and entry.service_start > entry.reach:
                    rospy.loginfo("%s waited %.2f s at %s for its predecessors", self.robot_ns[entry.robot],
                                  entry.service_start - entry.reach, self.scenario.tasks[entry.task].id)
        self._entries_seen = len(record.entries)
        self.pub_idle.publish(IdleTime(stamp=now, step=int(info.step), robots=self.robot_ns,
                                       idle_time=[float(t) for t in info.idle_time]))
        self._assigned = list(info.robot_tasks) if not (output.done or output.truncated) else [None] * len(self.robot_ns)
        if any(task is not None for task in self._assigned):
            self._driving.set()   # markers follow the robots between steps too (real robots drive on)
        self._publish_markers()

    def _robot_tasks(self) -> List[Optional[int]]:
        """Event mode: per robot the task it drives to, holds at or serves (the rules')."""
        return [robot.task for robot in self.env.rules.robots]

    @staticmethod
    def _deciding_of(output: StepOutput) -> List[bool]:
        if output.deciding is None:
            return [True] * len(output.obs)
        return [bool(flag) for flag in output.deciding]

    def _task_flags(self):
        """Per task: finished, and in order (None while open)."""
        if self.event:
            return list(self.env.rules.finished), list(self.env.record.task_logic_correct)
        return list(self.env.finished), list(self.env.task_correct)

    def _publish_markers(self, only_while_driving: bool = False) -> None:
        with self._marker_lock:   # the refresh thread never publishes an older state after a newer one
            if only_while_driving and not self._driving.is_set():
                return
            env = self.env
            if env.record is None:   # real robots: no episode yet
                return
            xy = [(p[0], p[1]) for p in self.executor.poses()]
            finished, correct = self._task_flags()
            self.pub_markers.publish(task_markers(self.scenario, self.settings.executor.map_frame, rospy.Time.now(),
                                                  finished, correct, list(self._assigned), xy))

    def _refresh_markers(self) -> None:
        """Robot -> goal lines follow the robots while they drive."""
        period = self.settings.marker_period
        while not rospy.is_shutdown():
            self._driving.wait(1.0)
            if self.pub_markers.get_num_connections() > 0:
                self._publish_markers(only_while_driving=True)
            rospy.rostime.wallsleep(period)
