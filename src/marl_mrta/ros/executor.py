"""The ROS executor: a decision step's goals driven through each robot's move_base.

Implements env.executor.Executor, and in event mode its event interface (ros/sim_events.py), so
the decision process (env/task_env.py, env/event_env.py) and every task rule stay the one ROS-free
implementation; this class only moves robots and reports what
happened: arrival and failure from the move_base results (their sim-time stamps), collisions
from /simulator/collisions, poses from ground truth.

Each leg has its own goal timeout (model/goal_timeout.py's LegTimeouts: fixed, or with auto from
the leg's nominal travel time in the scenario's travel table, from the node the robot stands on:
its start after a reset, the goal of the task it last reached). A synchronous step runs until
every goal has ended or its longest leg's timeout; a robot whose result comes after its own
timeout has failed ("goal timeout").

Between steps the simulator is paused, so the time this node needs to think never shows in
the world. A step starts on a tick aligned to `align_period` after every controller has
caught up, with every goal accepted by its move_base before time runs, and the simulator
pauses by itself on the tick of the step's deadline: in lock-step the same joint actions then
give the same robot motions whatever the machine's load (a pause requested when the deadline
is seen would land a few ticks later, differently from run to run, with robots still moving).

With several arenas in one simulator (parallel training) the clock is shared: another
arena's manager may be driving its robots at any time, so no manager pauses or steps the
simulator; each waits for sim time instead (between steps this arena's robots stand still,
which no reward or makespan counts). Steps then start on the first aligned tick after the
client's call, so such runs are not bit-repeatable.
"""
from __future__ import annotations

import math
import time
from contextlib import contextmanager
from typing import Iterator, List, Optional, Sequence, Set, Tuple

import rospy
from actionlib_msgs.msg import GoalStatus
from std_srvs.srv import Empty

from marl_mrta.env.executor import RobotOutcome, StepOutcome
from marl_mrta.evaluation.nav_comparison import is_stale_success
from marl_mrta.model.goal_timeout import LegTimeouts
from marl_mrta.model.scenario import Scenario
from marl_mrta.ros.manager_settings import RosExecutorSettings
from marl_mrta.ros.localization_link import LocalizationLink
from marl_mrta.ros.move_base_link import MoveBaseLink, await_accepted, cancel_running, send_goals
from marl_mrta.ros.sim_clock import SimClock, SimulatorLost, call_bounded, wait_wall
from marl_mrta.ros.sim_link import SimulatorLink
from marl_mrta.ros.sim_events import SimEventMode
from marl_mrta.ros.ticks import first_tick_at, sim_elapsed as _elapsed


#: s of sim time between the requests for an update without motion while amcl has not answered a
#: reset (about a scan period of TurtleBot3's LDS-01).
NOMOTION_PERIOD = 0.2


class StaleSuccessGuard:
    """Stock move_base may report a new goal reached at once, where the robot stands: the last
    goal's plan taken for it (ros-planning/navigation#949). Such a result (evaluation/
    nav_comparison.is_stale_success, against the ground truth) does not end the robot's goal: the
    goal is sent once more, and the step's times still count from its start."""

    def __init__(self, step_start: float):
        self.sent = step_start
        self.resent: Set[int] = set()   # robots whose goal was sent once more

    def all_ended(self, executor: "RosExecutor", goals: Sequence[Optional[int]], pending: Sequence[int]) -> bool:
        poses = None
        for i in pending:
            result = executor.bases[i].result
            if result is None or i in self.resent or not result.succeeded:
                continue
            poses = poses or executor.sim.poses()
            goal = executor.scenario.tasks[goals[i]].goal
            distance = math.hypot(poses[i][0] - goal.x, poses[i][1] - goal.y) if poses[i] is not None else None
            if is_stale_success(True, result.stamp - self.sent, distance):
                rospy.logwarn("%s: move_base reported goal %s reached %.2f s after it was sent, %.2f m away "
                              "(ros-planning/navigation#949): sent again", executor.namespaces[i],
                              executor.scenario.tasks[goals[i]].id, result.stamp - self.sent, distance)
                self.resent.add(i)
                executor.bases[i].send(goal.x, goal.y, goal.yaw)
        return all(executor.bases[i].result is not None for i in pending)


class RosExecutor(SimEventMode):
    """Executor over the simulator and the move_base nodes of one arena; in event mode the event
    interface of ros/sim_events.py."""

    def __init__(self, scenario: Scenario, settings: RosExecutorSettings, timeouts: LegTimeouts):
        self.scenario = scenario
        self.settings = settings
        self.timeouts = timeouts   # each leg's goal timeout, from where its robot stands
        self.n_robots = scenario.n_robots
        self.namespaces = [settings.robot_prefix + robot.id for robot in scenario.robots]
        self.lost_after = settings.lost_after(self.n_robots)
        self.sim = SimulatorLink(self.namespaces, settings.arena, self.lost_after)
        # Absolute names: with several arenas the manager runs in its arena's namespace (arena_k)
        # while the robot namespaces (arena_k/tb3_i) are the simulator's, from the root.
        self.bases = [MoveBaseLink("/" + ns, settings.map_frame) for ns in self.namespaces]
        self.clock = SimClock(self.lost_after, diagnose=self._diagnose, on_stall=self._on_stall)
        self.sim.on_stall = self._on_stall
        # amcl (stock or built-in) is told every reset pose; ground-truth localisation needs nothing.
        self.localizers = [LocalizationLink("/" + ns, settings.map_frame) for ns in self.namespaces] \
            if settings.localization == "amcl" else []
        self._starts = [(r.start.x, r.start.y, r.start.yaw) for r in scenario.robots]
        self._step_start = 0.0
        self._lost: Optional[str] = None   # set when a step was aborted: the next reset tries again
        self._init_events()

    # ------------------------------------------------------------------ start-up

    def wait_for_graph(self) -> None:
        """Blocks until the simulator and every move_base answer; raises SimulatorLost if not."""
        config = self.sim.wait_ready(self.settings.graph_wait)
        for base in self.bases:
            wait_wall(base.connected, self.settings.graph_wait, f"{base.server_name} did not connect")
        for link in self.localizers:
            wait_wall(link.connected, self.settings.graph_wait, f"{link.namespace}/amcl did not subscribe to initialpose")
        self._pause(True)
        self._await_first_answers()
        rospy.loginfo("simulator at %.0f Hz%s; move_base of %s connected", config.physics_rate,
                      ", lock-step" if config.lockstep else "", ", ".join(self.namespaces))

    @contextmanager
    def start_up_limits(self) -> Iterator[None]:
        """Within it every wait is bounded by graph_wait instead of lost_after: the first reset
        still belongs to the start-up, when a large team's controllers finish loading while
        planners (the reference of evaluate) may hold the CPUs."""
        running = self.lost_after
        self._set_lost_after(max(running, self.settings.graph_wait))
        try:
            yield
        finally:
            self._set_lost_after(running)

    def _set_lost_after(self, seconds: float) -> None:
        self.lost_after = self.sim.answer_wall = self.clock.lost_after_wall = seconds

    def _await_first_answers(self) -> None:
        """Steps until every controller's answer to a tick reaches this node, within graph_wait
        (simulator_lost_after is meant for a running graph). An answer sent while this node's
        subscription was still connecting is lost, and the paused simulator does not re-send a
        tick its controllers have answered: the next tick brings new answers. The ticks spent
        here change no episode (a reset restarts positions, costmaps and seeded noise)."""
        deadline = time.monotonic() + self.settings.graph_wait
        while True:
            tick, stamp = self._advance(1)
            try:
                self.sim.wait_caught_up(tick, stamp, timeout_wall=min(1.0, max(0.1, deadline - time.monotonic())))
                return
            except SimulatorLost:
                if time.monotonic() >= deadline:
                    raise SimulatorLost(f"no ground truth and lock-step answers of a tick within "
                                        f"{self.settings.graph_wait:.0f} s of wall time; "
                                        f"{self.sim.describe_lag(tick, stamp)}") from None

    # ------------------------------------------------------------------ Executor

    def reset(self, seed: Optional[int] = None) -> None:
        """Robots back to the scenario's start poses: goals cancelled, costmaps cleared, simulator
        paused on the reset state. With a `seed` the simulator restarts this arena's noise streams
        from it (and its `seed` parameter): the episode then never depends on how many ticks ran
        before it, at start-up or in earlier episodes. Without one the streams run on."""
        self._reset_events()
        self.sim.watch_again()   # a controller let out of the lock-step in the last episode is waited for again
        self._pause(True)
        self._cancel_running()
        # On an aligned tick, so that the controllers' costmap updates (restarted by the clearing
        # below) keep the same phase relative to every later step start.
        self._settle(align=True)
        self.sim.reset(self._starts, seed)
        for base in self.bases:
            base.forget()
            service = rospy.ServiceProxy(base.server_name + "/clear_costmaps", Empty)
            call_bounded(service, self.lost_after, f"{service.resolved_name}")
        self.sim.forget_poses()
        tick, stamp = self._advance(1)   # publishes the reset state
        self.sim.wait_caught_up(tick, stamp)
        if self.localizers:
            self._relocalise()
        self._lost = None

    def _relocalise(self) -> None:
        """Tells every robot's amcl its reset pose, then lets sim time run (the robots stand still)
        until each amcl_pose agrees with it. amcl answers on wall time, so the ticks this takes
        vary from run to run: episodes with amcl repeat only up to that (docs/guide/navigation.md)."""
        for link, start in zip(self.localizers, self._starts):
            link.reinitialise(start)
        s = self.settings
        rate = self.sim.config.physics_rate
        budget_ticks = int(math.ceil(s.localization_wait * rate))
        for waited in range(budget_ticks):
            errors = [link.error_to(start) for link, start in zip(self.localizers, self._starts)]
            if waited % max(1, int(round(NOMOTION_PERIOD * rate))) == 0:
                for link, error in zip(self.localizers, errors):
                    if error is None:
                        link.request_update()
            if all(e is not None and e[0] <= s.localization_tolerance_xy and e[1] <= s.localization_tolerance_yaw
                   for e in errors):
                # amcl future-dates map -> odom by its transform_tolerance: until that has passed,
                # a lookup could still blend in a transform of the odometry from before the reset.
                settle = int(math.ceil(s.localization_settle * rate))
                if settle:
                    self.sim.wait_caught_up(*self._advance(settle))
                return
            tick, stamp = self._advance(1)
            self.sim.wait_caught_up(tick, stamp)
            time.sleep(0.01)   # wall time for amcl to take the tick's scan
        lost = []
        for link, start in zip(self.localizers, self._starts):
            error = link.error_to(start)
            if error is None:
                lost.append(f"{link.namespace}: no amcl_pose since the reset")
            elif error[0] > s.localization_tolerance_xy or error[1] > s.localization_tolerance_yaw:
                lost.append(f"{link.namespace}: amcl_pose {error[0]:.2f} m / {error[1]:.2f} rad off")
        raise SimulatorLost(f"{'; '.join(lost)}: amcl_pose did not agree with the reset pose within "
                            f"{s.localization_tolerance_xy:g} m / {s.localization_tolerance_yaw:g} rad after "
                            f"{s.localization_wait:g} s of sim time")

    def start_step(self, goals: Sequence[Optional[int]], time_limit: float) -> StepOutcome:
        if self._lost is not None:
            return self._aborted(goals, None, self._lost)
        try:
            t0 = self._settle(align=True)
        except SimulatorLost as lost:
            return self._aborted(goals, None, str(lost))
        if self.shared_clock:
            t0 = max(t0, self.clock.now())   # time has run on since the aligned tick
        self._step_start = t0
        pending = send_goals(self.bases, self.scenario.tasks, goals)
        # Each robot's own limit; the step runs to the longest.
        limits = [min(time_limit, self.timeouts.limit(i, g)) if g is not None else 0.0 for i, g in enumerate(goals)]
        deadline = t0 + min(time_limit, self.timeouts.step_limit(goals))
        try:
            await_accepted(self.bases, pending, self.lost_after)
            stale = StaleSuccessGuard(t0)
            # Time runs only while a goal is under way. With none (every robot chose None, or every
            # goal ended on acceptance) nothing would pause the simulator but a request, which lands
            # a number of ticks later that depends on the load; finish_step runs the step's time.
            if not stale.all_ended(self, goals, pending):
                self._drive_until_ended(goals, pending, deadline, stale)
            # A goal that ended on the last tick may have its result still in flight (it travels
            # on another connection than the answer to that tick): it is cancelled too, and
            # waiting for every cancelled goal to end waits for that result, which a cancel of
            # an ended goal leaves as it was.
            self._cancel_running()
            end = min(self._settle(align=False), deadline)
        except SimulatorLost as lost:
            return self._aborted(goals, t0, str(lost))
        collisions = self.sim.collisions_between(t0, end)
        robots = []
        for i, goal in enumerate(goals):
            if goal is None:
                robots.append(RobotOutcome(has_goal=False, reached=False, nav_time=0.0, collisions=collisions[i]))
                continue
            result, limit = self.bases[i].result, limits[i]
            # A preempted goal is one this executor cancelled at the deadline: a timeout; so is a
            # result after the robot's own deadline.
            if result is not None and result.stamp <= t0 + limit + 1e-9 and result.state != GoalStatus.PREEMPTED:
                nav_time = min(_elapsed(t0, max(result.stamp, t0)), limit)
                failure = "" if result.succeeded else result.describe()
                robots.append(RobotOutcome(True, result.succeeded, nav_time, collisions[i], failure))
                if result.succeeded:
                    self.timeouts.reached(i, goal)
            else:
                robots.append(RobotOutcome(True, False, limit, collisions[i], "goal timeout"))
        return StepOutcome(robots=robots)

    def _drive_until_ended(self, goals: Sequence[Optional[int]], pending: Sequence[int], deadline: float,
                           stale: StaleSuccessGuard) -> None:
        """Lets sim time run until every pending goal has ended or the deadline; then paused."""
        watched = [i for i in pending if self.bases[i].result is None and self._reports_goal_ends(i)]
        self._run_until(deadline, watched)
        watching = bool(watched)

        def ended() -> bool:
            nonlocal watching
            done = stale.all_ended(self, goals, pending)
            if watching and stale.resent:
                # A goal sent once more ends after the goal ends the simulator watches for (or
                # it counted the stale one): it would pause before that goal's end.
                self._run_until(deadline)
                watching = False
            return done

        if self.clock.wait_until(ended, deadline) and watching:
            self._await_early_pause(watched, deadline)
        self._pause(True)
        self.sim.wait_caught_up(*self.sim.step(0))   # every controller has seen the last tick

    def finish_step(self, duration: float) -> None:
        """Lets sim time run to the step's end (service and idle time: the robots stand still)."""
        if self._lost is not None:
            return
        try:
            tick, now = self.sim.step(0)
            rate = self.sim.config.physics_rate
            ticks = first_tick_at(self._step_start + duration - now, rate)
            if ticks > 0:
                self._advance(ticks)
            self._settle(align=False)
        except SimulatorLost as lost:
            self._lost = str(lost)   # reported as the abort of the next step

    def poses(self) -> List[Tuple[float, float, float]]:
        return [pose if pose is not None else start for pose, start in zip(self.sim.poses(), self._starts)]

    # ------------------------------------------------------------------ helpers

    @property
    def shared_clock(self) -> bool:
        """Several arenas in the simulator: other managers drive on the same clock (module doc)."""
        return self.sim.config is not None and self.sim.config.arenas > 1

    def _pause(self, paused: bool) -> None:
        if not self.shared_clock:
            self.sim.pause(paused)

    def _run_until(self, stamp: float, watched: Sequence[int] = ()) -> None:
        """Lets sim time run (lock-step as configured) to the first tick at or after `stamp`,
        where the simulator pauses by itself; on a shared clock time runs anyway. With `watched`
        robots it pauses earlier, on the first aligned tick after the last of their goals ended."""
        if not self.shared_clock:
            self.sim.run_until(first_tick_at(stamp, self.sim.config.physics_rate),
                               [self.namespaces[i] for i in watched], self._align_ticks())

    def _reports_goal_ends(self, robot: int) -> bool:
        """The robot's move_base answers the lock-step, so the simulator sees its goals end."""
        return not self.shared_clock and self.sim.config.answers_lockstep(self.namespaces[robot])

    def _align_ticks(self) -> int:
        return max(1, int(round(self.settings.align_period * self.sim.config.physics_rate)))

    def _await_early_pause(self, watched: Sequence[int], deadline: float) -> None:
        """Every goal has ended: when the simulator watches them (run_until), waits until it has
        paused by itself on the aligned tick after the last end, the tick it reached whatever the
        load; a pause requested now would land a varying number of ticks later."""
        if not watched:
            return
        rate = self.sim.config.physics_rate
        align = self._align_ticks()
        last_end = max(int(round(self.bases[i].result.stamp * rate)) for i in watched)
        pause_stamp = int(math.ceil(last_end / align)) * align / rate
        self.clock.wait_until(lambda: self.clock.now() >= pause_stamp - 1e-9, deadline)

    def _advance(self, ticks: int) -> Tuple[int, float]:
        """`ticks` more ticks: stepped when paused (or run through the lock-step with
        advance_in_lockstep), waited for on a shared clock. Returns the tick and sim time reached."""
        if not self.shared_clock and not (self.settings.advance_in_lockstep and ticks > 1):
            return self.sim.step(ticks)
        tick, _ = self.sim.step(0)
        target = tick + ticks
        stamp = target / self.sim.config.physics_rate
        if not self.shared_clock:
            # Stock move_base's costmaps take a burst of ticks for stale transforms ("Could not
            # get robot pose"): the ticks run through the lock-step, where its stock_lockstep
            # node answers each, and the simulator pauses on the target tick.
            self.sim.run_until(target)
        self.clock.wait_until(lambda: self.clock.now() >= stamp - 1e-9)
        return target, stamp

    def _settle(self, align: bool) -> float:
        """With the simulator paused: optionally step to the next aligned tick, then wait until
        every controller and the ground truth have caught up. Returns the sim time. The current
        tick's state is always waited for, never stepped past: it may still be in flight, and a
        tick stepped for it would land on some runs and not on others (wait_for_graph has made
        sure that this node hears every tick's state)."""
        tick, stamp = self.sim.step(0)
        period = self._align_ticks() if align else 1
        ticks = (period - tick % period) % period
        if ticks:
            tick, stamp = self._advance(ticks)
        self.sim.wait_caught_up(tick, stamp)
        return stamp

    def _cancel_running(self) -> None:
        """Cancels every goal still running and waits until move_base has stopped it. The built-in
        move_base stops at once, within the paused tick. Stock move_base stops only between its
        recovery behaviours, which run on sim time (rotate_recovery turns a full circle): a goal
        not stopped within lost_after lets sim time run on until it is, up to cancel_wait."""
        try:
            cancel_running(self.bases, self.lost_after)
            return
        except SimulatorLost:
            pass
        running = [i for i, base in enumerate(self.bases) if not base.idle]
        limit = self.clock.now() + self.settings.cancel_wait
        rospy.logwarn("move_base of %s: a cancelled goal still runs (a recovery behaviour); sim time runs on "
                      "until it ends, at most %.0f s", ", ".join(self.namespaces[i] for i in running),
                      self.settings.cancel_wait)
        self._run_until(limit)
        ended = self.clock.wait_until(lambda: all(self.bases[i].idle for i in running), limit)
        self._pause(True)
        if not ended:
            still = ", ".join(self.namespaces[i] for i in running if not self.bases[i].idle)
            raise SimulatorLost(f"move_base of {still} did not end a cancelled goal within "
                                f"{self.settings.cancel_wait:.0f} s of sim time")
        self.sim.wait_caught_up(*self.sim.step(0))

    def _aborted(self, goals: Sequence[Optional[int]], t0: Optional[float], reason: str) -> StepOutcome:
        """The step cannot go on: stop what can be stopped, report every robot as failed."""
        self._lost = reason
        for base in self.bases:
            base.cancel()
        try:
            self._pause(True)
        except SimulatorLost:
            pass
        elapsed = max(0.0, _elapsed(t0, self.clock.now())) if t0 is not None else 0.0
        robots = [RobotOutcome(has_goal=g is not None, reached=False, nav_time=elapsed if g is not None else 0.0,
                               failure="aborted" if g is not None else "") for g in goals]
        return StepOutcome(robots=robots, aborted=True, abort_reason=reason)

    def _on_stall(self) -> bool:
        """The lock-step stalled (no answer for lost_after): with on_robot_fault continue while an
        episode runs, the robots whose controller is silent and whose move_base process is gone
        leave the fleet (sim_events.py). True when one did: the wait goes on without it."""
        if self.shared_clock or not self.sim.tracks_answers:
            return False
        try:
            tick, _ = self.sim.step(0, timeout_wall=1.0)
        except SimulatorLost:
            return False   # the simulator itself does not answer
        return self._lose_if_gone(self.sim.silent_controllers(tick))

    def _diagnose(self) -> str:
        """Why /clock stopped: the simulator does not answer, or it waits for a controller."""
        try:
            tick, _ = self.sim.step(0, timeout_wall=1.0)
        except SimulatorLost:
            return "the simulator does not answer"
        return f"the simulator waits at tick {tick}: {self.sim.describe_lag(tick)}"
