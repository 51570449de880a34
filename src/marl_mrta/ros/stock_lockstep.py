"""When to answer the simulator's lock-step ticks for a stock move_base (ROS-free; the node is
apps/stock_lockstep_node.py).

Stock move_base does not take part in the lock-step protocol (docs/reference/nodes_sim_nav.md). Its control
loop runs on sim time, though: while it pursues a goal it wakes every control period
(1 / controller_frequency) counted from the moment it accepted the goal, and publishes one
cmd_vel. So the robot's velocity command for a control tick is its answer to that tick: the
relay holds the simulator on a control tick until the command has come (or `command_wait` wall
seconds have passed: move_base also has cycles without a command, while it plans or clears its
costmaps), and lets it run through the ticks in between. When its global planner has found no
path to the goal (it publishes the empty plan) and a control tick has passed without a command,
move_base sends none until planner_patience ends in a recovery behaviour or a plan is found: the
ticks are then answered at once until a command or a plan comes, instead of each waiting
`command_wait` (a tenth of sim time's pace). A goal's first plan is waited for as before: it may
take long on a loaded machine. Without a goal it answers every tick
after `idle_wait` wall seconds: move_base's costmaps update in threads of their own, which
nothing waits for, and a burst of ticks (the task manager stepping to a whole second after a
reset) would otherwise leave them behind the robots' poses when the next goals come. With a
particle filter (stock amcl, `localization_tolerance` > 0) every answer also waits, at most
`command_wait`, until the filter's map -> odom of the latest scan has come (amcl post-dates it
by its transform_tolerance): at full speed it otherwise falls behind the controller, whose map ->
odom lookups then fail. The result of a goal is reported on the tick of the result's stamp, as
the built-in move_base does. What this keeps deterministic, and what not: docs/guide/navigation.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Optional

from marl_mrta.ros.ticks import first_tick_at

# A tick's stamp and a control time computed from another stamp may differ in the last
# nanoseconds; this is far below the physics tick.
STAMP_SLACK = 1e-6


@dataclass(frozen=True)
class TickAnswer:
    """The fields of marl_mrta/LockstepAck for one robot."""
    tick: int
    cmd_vel_count: int
    next_stamp: float      # sim s; 0: the very next tick is needed
    goal_end_tick: int


class StockLockstepRule:
    """One robot's answers. Calls: on_goal / on_result / on_command as move_base's messages
    come; on_tick for every SimTick; then answer(wall_now) until it returns a TickAnswer,
    waiting at most wait_left(wall_now) between calls for a message to come."""

    def __init__(self, control_period: float, physics_rate: float, command_wait: float = 0.5,
                 result_wait: float = 0.05, idle_wait: float = 0.005, localization_tolerance: float = 0.0):
        if not (control_period > 0.0 and physics_rate > 0.0 and min(command_wait, result_wait, idle_wait) >= 0.0):
            raise ValueError("control_period and physics_rate must be > 0, the waits >= 0")
        self.control_period = control_period
        self.physics_rate = physics_rate
        self.command_wait = command_wait
        self.result_wait = result_wait
        self.idle_wait = idle_wait
        self.localization_tolerance = localization_tolerance   # 0: no particle filter to wait for
        self.localized_stamp = 0.0        # latest map -> odom stamp of the filter (0: none yet)
        self._scan_stamp = 0.0            # the latest scan at or before the current tick
        self.commands = 0                 # cmd_vel messages seen since start
        self.goal_active = False
        self.goal_end_tick = 0
        self.control_stamp: Optional[float] = None   # next control time of the active goal; None: not known
        self.timeouts = 0                 # control ticks answered without a command (for the log)
        self.silent = False               # a control tick was answered without a command since the last one
        self.plan_failed = False          # the global planner's latest plan for this goal was empty
        self.quiet_ticks = 0              # ticks answered at once while move_base had no path (for the log)
        self._last_stamp = 0.0            # stamp of the latest tick seen
        self._tick: Optional[int] = None  # the tick being answered
        self._answered: Optional[TickAnswer] = None
        self._due_answered = -math.inf    # stamp of the latest control tick answered (or phase set)
        self._commanded = False           # a command was sent after it: it answers the next control tick
        self._waiting = False
        self._deadline = 0.0
        self._idle_until = 0.0
        self._result_deadline: Optional[float] = None
        self._last_command_zero = False

    # ------------------------------------------------------------------ move_base's messages

    def on_goal(self) -> None:
        """move_base accepted a goal: its first command comes one control period after the tick
        it accepted it on (the first cycle plans)."""
        if not self.goal_active:   # a goal that replaces a running one keeps move_base's loop
            self.control_stamp = self._last_stamp + self.control_period
            self._due_answered, self._commanded = self._last_stamp, False
        self.goal_active = True
        self.silent = False
        self.plan_failed = False

    def on_result(self, stamp: float) -> None:
        self.goal_active = False
        self.control_stamp = None
        self.silent = False
        self.plan_failed = False
        self.goal_end_tick = max(self.goal_end_tick, self.tick_of(stamp))

    def on_localization(self, stamp: float) -> None:
        """The particle filter sent map -> odom stamped `stamp`."""
        self.localized_stamp = max(self.localized_stamp, stamp)

    def _localized(self) -> bool:
        """The filter has answered the latest scan (or there is none to wait for: no filter, no
        transform from it yet, or no scan yet)."""
        if self.localization_tolerance <= 0.0 or self.localized_stamp == 0.0 or self._scan_stamp == 0.0:
            return True
        return self.localized_stamp >= self._scan_stamp + self.localization_tolerance - STAMP_SLACK

    def on_plan(self, empty: bool) -> None:
        """move_base's global planner published a plan (empty: it found no path)."""
        self.plan_failed = empty

    @property
    def quiet(self) -> bool:
        """move_base pursues a goal it has no path to and has let a control tick pass without a command."""
        return self.goal_active and self.plan_failed and self.silent

    def on_command(self, is_zero: bool, stamp: Optional[float] = None) -> None:
        """move_base sent a command; `stamp`: the sim time it came at by the node's clock, which
        may lag (the latest tick seen counts as well). The simulator runs through the ticks between
        control ticks without their answers, so a control tick's command may come before the tick
        before it does: a command answers the next control tick if it was sent after the last one
        answered (a second command of that tick's cycle, e.g. a stop before a recovery, does not)."""
        stamp = self._last_stamp if stamp is None else max(stamp, self._last_stamp)
        quiet = self.quiet
        self.silent = False
        self.commands += 1
        if quiet:   # its control loop runs again: the next command one period after this one
            self.control_stamp = stamp + self.control_period
            self._due_answered, self._commanded = stamp, False
        elif stamp > self._due_answered + STAMP_SLACK:
            self._commanded = True
        self._last_command_zero = is_zero

    # ------------------------------------------------------------------ ticks

    @property
    def tick_period(self) -> float:
        return 1.0 / self.physics_rate

    def tick_of(self, stamp: float) -> int:
        return first_tick_at(stamp, self.physics_rate)

    def on_tick(self, tick: int, stamp: float, wall_now: float, scan_stamp: float = 0.0) -> None:
        if tick == self._tick:
            return   # re-sent: answered again as before
        self._tick, self._answered = tick, None
        self._last_stamp = stamp
        self._scan_stamp = scan_stamp
        quiet = self.quiet
        self.quiet_ticks += quiet
        due = self.goal_active and not quiet and (
            self.control_stamp is None or stamp >= self.control_stamp - STAMP_SLACK)
        self._waiting = due
        self._deadline = wall_now + self.command_wait
        self._idle_until = wall_now + self.idle_wait if not self.goal_active else wall_now
        self._result_deadline = None

    def answer(self, wall_now: float) -> Optional[TickAnswer]:
        """The answer to the current tick, or None while its command is awaited."""
        if self._tick is None:
            return None
        if self._answered is None and not self._localized() and wall_now < self._deadline:
            return None
        if self._answered is not None:   # a re-sent tick: what came since counts too
            self._answered = replace(self._answered, cmd_vel_count=self.commands, goal_end_tick=self.goal_end_tick)
            return self._answered
        if self._waiting:
            if not self._commanded:
                if wall_now < self._deadline:
                    return None
                self.timeouts += 1
                self.silent = True
                self.control_stamp = None   # a cycle without a command: look for the next on every tick
            else:
                if self._last_command_zero and self.goal_active:
                    # move_base stops the robot just before it sends a goal's result: the result
                    # then counts on this tick, as it does with the built-in move_base.
                    if self._result_deadline is None:
                        self._result_deadline = wall_now + self.result_wait
                    if wall_now < self._result_deadline:
                        return None
                self.control_stamp = self._last_stamp + self.control_period if self.goal_active else None
            self._due_answered, self._commanded = self._last_stamp, False
        elif not self.goal_active and wall_now < self._idle_until:
            return None
        next_stamp = self.control_stamp if (self.goal_active and self.control_stamp is not None) else 0.0
        if next_stamp and next_stamp <= self._last_stamp + STAMP_SLACK:
            next_stamp = 0.0
        self._answered = TickAnswer(self._tick, self.commands, next_stamp - STAMP_SLACK if next_stamp else 0.0,
                                    self.goal_end_tick)
        return self._answered

    def wait_left(self, wall_now: float) -> float:
        if not self._localized():
            return max(0.0, self._deadline - wall_now)
        if not self._waiting:
            return max(0.0, self._idle_until - wall_now)
        deadline = self._deadline if self._result_deadline is None else min(self._deadline, self._result_deadline)
        return max(0.0, deadline - wall_now)
