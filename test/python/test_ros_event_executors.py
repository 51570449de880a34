"""Event mode's executors with test doubles for the move_base links, the safety monitor, the clock
and the simulator. Real robots (ros/real_events.py): the first leg to end is reported while the
other drives on, a leg past its goal timeout is cancelled and fails without stopping the fleet, and
a goal move_base aborts, or any stop, ends the episode with every robot stopped, as in synchronous
mode. The simulator (ros/sim_events.py): it is asked to pause on the first watched goal end or on
the earliest leg deadline, and a stale success is driven once more. With auto goal timeouts each leg
has its own, from where its robot stands: a synchronous step on real robots waits for its longest
leg and judges each robot by its own, and a leg reached in the simulation moves its robot's next
deadline."""
from types import SimpleNamespace

import pytest

pytest.importorskip("tf2_ros", reason="ROS Python packages (the system's)")

from actionlib_msgs.msg import GoalStatus  # noqa: E402

from marl_mrta.env.executor import LegEnd  # noqa: E402
from marl_mrta.model.goal_timeout import GoalTimeout, LegTimeouts  # noqa: E402
from marl_mrta.ros import real_events  # noqa: E402
from marl_mrta.ros.move_base_link import GoalResult  # noqa: E402
from marl_mrta.ros.real_executor import RealExecutor  # noqa: E402


class Clock:
    """Wall time that moves only while the executor sleeps; `events` fire at their times."""

    def __init__(self):
        self.now = 100.0
        self.events = []   # (time, action)

    def sleep(self, seconds):
        self.now += seconds
        for due, action in [e for e in self.events if e[0] <= self.now + 1e-12]:
            self.events.remove((due, action))
            action()


class FakeBase:
    def __init__(self, clock, name):
        self.clock, self.namespace = clock, name
        self.result, self.sent, self.cancels, self.accepted = None, [], 0, False

    def send(self, x, y, yaw):
        self.sent.append((x, y))
        self.result, self.accepted = None, True

    def end(self, state, text=""):
        self.result = GoalResult(state, text, self.clock.now)

    def cancel(self):
        self.cancels += 1
        if self.result is None:
            self.end(GoalStatus.PREEMPTED)

    @property
    def idle(self):
        return not self.sent or self.result is not None


class FakeRealRobots(real_events.RealEventMode):
    _failed_goal = RealExecutor._failed_goal
    start_step = RealExecutor.start_step   # synchronous mode's step (real_executor.py)

    def __init__(self, clock, goal_timeout=10.0):
        self.n_robots = 2
        self.namespaces = ["tb3_0", "tb3_1"]
        goal = SimpleNamespace(x=1.0, y=2.0, yaw=0.0)
        self.scenario = SimpleNamespace(tasks=[SimpleNamespace(id=f"T{j}", goal=goal) for j in range(3)])
        self.settings = SimpleNamespace(simulator_lost_after=1.0, cancel_wait=1.0, on_robot_fault="stop_fleet")
        self.timeouts = LegTimeouts(GoalTimeout(goal_timeout), self.n_robots)
        self.bases = [FakeBase(clock, "/" + ns) for ns in self.namespaces]
        self.monitor = SimpleNamespace(tripped=False, reason="")
        self.stops = []
        self._lost = None
        self._step_start = 0.0
        self._init_events()

    def trip(self, reason, log=True):
        self.stops.append(reason)
        if not self.monitor.tripped:
            self.monitor.tripped, self.monitor.reason = True, reason


@pytest.fixture
def robots(monkeypatch):
    clock = Clock()
    monkeypatch.setattr(real_events.rospy, "get_time", lambda: clock.now)
    monkeypatch.setattr(real_events.time, "sleep", clock.sleep)
    from marl_mrta.ros import real_executor
    monkeypatch.setattr(real_executor.rospy, "get_time", lambda: clock.now)
    monkeypatch.setattr(real_executor.time, "sleep", clock.sleep)
    executor = FakeRealRobots(clock)
    executor.clock = clock
    return executor


def test_the_first_leg_to_end_is_reported_while_the_other_drives_on(robots):
    clock = robots.clock
    robots.dispatch(0, 0)
    robots.dispatch(1, 1)
    clock.events.append((clock.now + 3.0, lambda: robots.bases[0].end(GoalStatus.SUCCEEDED, "Goal reached.")))
    result = robots.advance(until=50.0)
    assert not result.aborted and result.legs == [LegEnd(0, True)]
    assert 3.0 <= result.time < 3.05
    assert robots.bases[1].cancels == 0 and robots.legs.running() == [1]
    # tb3_1's leg reaches its goal timeout (10 s after its start): cancelled, failed, no stop.
    result = robots.advance(until=50.0)
    assert result.legs == [LegEnd(1, False, "goal timeout")] and 10.0 <= result.time < 10.05
    assert robots.bases[1].cancels == 1 and robots.stops == []
    # Nothing runs: the wait ends at `until`.
    assert 12.5 <= robots.advance(until=12.5).time < 12.55


# Auto goal timeouts: nodes are the robots' starts, then the goals of tasks T0, T1, T2.
NOMINAL = [[0.0, 5.0, 10.0, 40.0, 20.0],
           [5.0, 0.0, 30.0, 40.0, 35.0],
           [10.0, 30.0, 0.0, 15.0, 25.0],
           [40.0, 40.0, 15.0, 0.0, 5.0],
           [20.0, 35.0, 25.0, 5.0, 0.0]]


def test_a_synchronous_step_waits_for_its_longest_leg_and_judges_each_robot_by_its_own(robots):
    """tb3_0's leg to T0 (nominal 10 s) may take 2 x 10 + 30 = 50 s, tb3_1's to T1 (40 s) 110 s:
    tb3_0 arriving after 60 s has failed it, tb3_1 after 100 s has not, and only tb3_1 now stands
    on its task's goal, from where its next leg's timeout is taken."""
    clock = robots.clock
    robots.timeouts = robots.legs.timeouts = LegTimeouts(GoalTimeout(None, 2.0, 30.0), 2, NOMINAL)
    t0 = clock.now
    clock.events += [(t0 + 60.0, lambda: robots.bases[0].end(GoalStatus.SUCCEEDED, "Goal reached.")),
                     (t0 + 100.0, lambda: robots.bases[1].end(GoalStatus.SUCCEEDED, "Goal reached."))]
    outcome = robots.start_step([0, 1], time_limit=600.0)
    assert [(r.reached, r.failure) for r in outcome.robots] == [(False, "goal timeout"), (True, "")]
    assert outcome.robots[0].nav_time == 50.0 and outcome.robots[1].nav_time == pytest.approx(100.0, abs=0.02)
    assert robots.timeouts.nodes == [0, 3]
    assert robots.timeouts.limit(1, 2) == 2 * 5.0 + 30.0 and robots.timeouts.limit(0, 2) == 2 * 20.0 + 30.0
    # No result at all: the step ends at its longest leg's timeout, the episode's time limit capping it.
    t1 = clock.now
    outcome = robots.start_step([None, 2], time_limit=30.0)
    assert outcome.robots[1].failure == "goal timeout" and outcome.robots[1].nav_time == 30.0
    assert 30.0 <= clock.now - t1 < 30.05


def test_a_goal_move_base_aborts_stops_every_robot_and_ends_the_episode(robots):
    clock = robots.clock
    robots.dispatch(0, 0)
    robots.dispatch(1, 1)
    clock.events.append((clock.now + 2.0, lambda: robots.bases[1].end(GoalStatus.ABORTED, "Failed to find a valid plan.")))
    result = robots.advance(until=50.0)
    assert result.aborted and result.abort_reason.startswith("tb3_1: move_base aborted: Failed to find a valid plan")
    assert robots.stops == [result.abort_reason] and robots.legs.running() == []
    assert robots.advance(until=50.0).aborted   # no leg goes on after a stop
    robots.dispatch(0, 2)
    assert len(robots.bases[0].sent) == 1


def test_a_stop_while_robots_drive_ends_the_episode_with_its_reason(robots):
    clock = robots.clock
    robots.dispatch(0, 0)
    clock.events.append((clock.now + 1.0, lambda: robots.trip("e-stop (~estop)")))
    result = robots.advance(until=50.0)
    assert result.aborted and result.abort_reason == "e-stop (~estop)"
    assert 1.0 <= result.time < 1.05


# ---------------------------------------------------------------------------------------------
# The simulator's side (ros/sim_events.py), with a simulator double that pauses by itself as
# /simulator/run_until does: on the first watched goal end, or on the tick asked for.
from marl_mrta.ros import sim_events  # noqa: E402

RATE = 20.0


class FakeSimulator:
    def __init__(self, executor):
        self.executor = executor
        self.tick = 40
        self.config = SimpleNamespace(physics_rate=RATE)
        self.ends = {}         # robot -> (tick, state) on which its goal will end
        self.goal_end = [0, 0]
        self.runs = []

    def step(self, ticks=0):
        return self.tick, self.tick / RATE

    def run_until(self, tick, watched, align, first_goal_end=False):
        self.runs.append((tick, list(watched), align, first_goal_end))
        ends = [t for t, _ in self.ends.values() if t > self.tick]
        self.tick = min([tick] + ends)
        for robot, (end, state) in list(self.ends.items()):
            if end <= self.tick:
                self.goal_end[robot] = end
                self.executor.bases[robot].result = GoalResult(state, "", end / RATE)
                del self.ends[robot]

    def goal_end_tick(self, robot):
        return self.goal_end[robot]

    def wait_caught_up(self, tick, stamp):
        pass

    def poses(self):
        return [(1.0, 2.0, 0.0), (9.0, 9.0, 0.0)]

    def collisions_between(self, start, end):
        return [0, 0]


class FakeSimRobots(sim_events.SimEventMode):
    def __init__(self, goal_timeout=10.0):
        self.n_robots = 2
        self.namespaces = ["tb3_0", "tb3_1"]
        goal = SimpleNamespace(x=1.0, y=2.0, yaw=0.0)
        self.scenario = SimpleNamespace(tasks=[SimpleNamespace(id=f"T{j}", goal=goal) for j in range(3)])
        self.settings = SimpleNamespace(on_robot_fault="stop_fleet")
        self.timeouts = LegTimeouts(GoalTimeout(goal_timeout), self.n_robots)
        self.lost_after = 1.0
        self.shared_clock = False
        self.bases = [FakeBase(SimpleNamespace(now=0.0), "/" + ns) for ns in self.namespaces]
        self.sim = FakeSimulator(self)
        self.clock = SimpleNamespace(now=lambda: self.sim.tick / RATE,
                                     wait_until=lambda predicate, deadline=None: predicate())
        self._lost = None
        self._init_events()

    def _settle(self, align):
        return self.sim.tick / RATE

    def _pause(self, paused):
        pass

    def _reports_goal_ends(self, robot):
        return True


def test_the_simulator_pauses_on_the_first_goal_end_and_a_leg_times_out_on_its_own_deadline():
    robots = FakeSimRobots(goal_timeout=30.0)
    robots.dispatch(0, 0)
    robots.dispatch(1, 1)
    robots.sim.ends = {0: (100, GoalStatus.SUCCEEDED)}   # tb3_1 never arrives
    result = robots.advance(until=20.0)
    assert robots.sim.runs[-1] == (40 + 20 * 20, ["tb3_0", "tb3_1"], 1, True)
    assert result.legs == [LegEnd(0, True)] and result.time == pytest.approx(3.0)
    assert robots.legs.running() == [1] and robots.bases[1].cancels == 0
    # tb3_1's deadline (30 s after the start) comes before `until`: the run stops there.
    result = robots.advance(until=50.0)
    assert robots.sim.runs[-1] == (40 + 30 * 20, ["tb3_1"], 1, True)
    assert result.legs == [LegEnd(1, False, "goal timeout")] and result.time == pytest.approx(30.0)
    assert robots.bases[1].cancels == 1


def test_a_stale_success_is_driven_once_more_and_two_ends_on_one_tick_are_one_event():
    robots = FakeSimRobots()
    robots.dispatch(0, 0)
    robots.dispatch(1, 1)
    # tb3_1 is told it arrived one tick after the goal, 10 m away (ros-planning/navigation#949).
    robots.sim.ends = {0: (80, GoalStatus.SUCCEEDED), 1: (41, GoalStatus.SUCCEEDED)}
    result = robots.advance(until=50.0)
    assert result.legs == [] and len(robots.bases[1].sent) == 2 and robots.legs.running() == [0, 1]
    robots.sim.ends[1] = (80, GoalStatus.SUCCEEDED)
    result = robots.advance(until=50.0)
    assert result.legs == [LegEnd(0, True), LegEnd(1, True)] and result.time == pytest.approx(2.0)


def test_with_auto_a_leg_reached_in_the_simulation_moves_its_robots_next_deadline():
    """Event mode on the simulator: tb3_0 reaches T0 at 3 s; its next leg, to T1, may take
    2 x 15 + 30 s from there (not the 2 x 40 + 30 s from its start); tb3_1's failed leg leaves it
    on its start."""
    robots = FakeSimRobots()
    robots.timeouts = robots.legs.timeouts = LegTimeouts(GoalTimeout(None, 2.0, 30.0), 2, NOMINAL)
    robots.dispatch(0, 0)
    robots.dispatch(1, 2)
    assert [robots.legs.legs[i].deadline for i in (0, 1)] == [2 * 10.0 + 30.0, 2 * 35.0 + 30.0]
    robots.sim.ends = {0: (100, GoalStatus.SUCCEEDED), 1: (120, GoalStatus.ABORTED)}
    assert robots.advance(until=200.0).legs == [LegEnd(0, True)]
    robots.dispatch(0, 1)
    assert robots.legs.legs[0].deadline == pytest.approx(3.0 + 2 * 15.0 + 30.0)
    assert robots.advance(until=200.0).legs[0].robot == 1
    assert robots.timeouts.nodes == [2, 1]


# ---------------------------------------------------------------------------------------------
# A live fleet (env/live_fleet.py): stop(), add_goals(), a request that ends a wait, and with
# on_robot_fault continue a robot's own fault stopping it alone, reported in `left`.

class FakeFleetStop:
    def __init__(self):
        self.alone, self.granted = [], []

    def stop_robot(self, robot):
        self.alone.append(robot)

    def grant_robot(self, robot=None):
        self.granted.append(robot)


def continuing(robots):
    robots.settings.on_robot_fault = "continue"
    robots.fleet_stop = FakeFleetStop()
    robots.monitor.excused = set()
    robots.monitor.excuse = robots.monitor.excused.add
    robots.monitor.watch_again = robots.monitor.excused.discard
    return robots


def test_stop_cancels_a_robots_goal_and_ends_its_leg_without_a_report(robots):
    robots.dispatch(0, 0)
    robots.dispatch(1, 1)
    robots.stop(1)
    assert robots.bases[1].cancels == 1 and robots.legs.running() == [0]
    robots.clock.events.append((robots.clock.now + 2.0, lambda: robots.bases[0].end(GoalStatus.SUCCEEDED)))
    result = robots.advance(until=50.0)
    assert result.legs == [LegEnd(0, True)] and result.left == [] and robots.stops == []


def test_a_waiting_request_ends_the_wait_at_once(robots):
    robots.dispatch(0, 0)
    waiting = [False]
    robots.interrupted = lambda: waiting[0]
    robots.clock.events.append((robots.clock.now + 1.5, lambda: waiting.__setitem__(0, True)))
    result = robots.advance(until=50.0)
    assert result.legs == [] and 1.5 <= result.time < 1.55 and robots.legs.running() == [0]


def test_submitted_goals_are_dispatched_with_their_own_timeouts(robots):
    goal = SimpleNamespace(x=5.0, y=6.0, yaw=0.0)
    scenario = SimpleNamespace(tasks=robots.scenario.tasks + [SimpleNamespace(id="X1", goal=goal)])
    robots.timeouts = robots.legs.timeouts = LegTimeouts(GoalTimeout(None, 2.0, 30.0), 2, NOMINAL)
    table = SimpleNamespace(nominal_time=[row + [7.0] for row in NOMINAL] + [[7.0] * 5 + [0.0]])
    robots.add_goals(scenario, table)
    robots.dispatch(0, 3)
    assert robots.bases[0].sent[-1] == (5.0, 6.0)
    assert robots.legs.legs[0].deadline == pytest.approx(2 * 7.0 + 30.0)


def test_with_continue_a_goal_aborted_stops_that_robot_alone_and_the_other_drives_on(robots):
    clock = continuing(robots).clock
    robots.dispatch(0, 0)
    robots.dispatch(1, 1)
    clock.events.append((clock.now + 2.0, lambda: robots.bases[1].end(GoalStatus.ABORTED, "Failed to find a valid plan.")))
    result = robots.advance(until=50.0)
    assert not result.aborted and robots.stops == []
    assert result.left == [(1, "tb3_1: move_base aborted: Failed to find a valid plan.")]
    assert robots.fleet_stop.alone == [1] and 1 in robots.monitor.excused and robots.legs.running() == [0]
    clock.events.append((clock.now + 3.0, lambda: robots.bases[0].end(GoalStatus.SUCCEEDED)))
    result = robots.advance(until=50.0)
    assert result.legs == [LegEnd(0, True)] and result.left == []
    robots.take_back(1)   # it joins again: watched again, may drive again
    assert 1 not in robots.out_of_fleet and 1 not in robots.monitor.excused and robots.fleet_stop.granted == [1]


def test_with_continue_the_watchdogs_fault_of_one_robot_ends_the_wait_and_a_fleet_fault_stops_all(robots):
    clock = continuing(robots).clock
    robots.dispatch(0, 0)
    robots.dispatch(1, 1)
    clock.events.append((clock.now + 1.0, lambda: robots.robot_fault(0, "tb3_0: odom silent for 1.1 s")))
    result = robots.advance(until=50.0)
    assert result.left == [(0, "tb3_0: odom silent for 1.1 s")] and 1.0 <= result.time < 1.05
    assert robots.legs.running() == [1] and robots.stops == []
    robots.robot_fault(0, "tb3_0: odom silent for 2.0 s")   # out already: nothing more
    assert robots.fleet_stop.alone == [0]
    clock.events.append((clock.now + 1.0, lambda: robots.trip("ROS master unreachable for 1.2 s")))
    result = robots.advance(until=50.0)
    assert result.aborted and result.abort_reason == "ROS master unreachable for 1.2 s"


def test_before_the_episode_a_robots_fault_stops_every_robot_even_with_continue(robots):
    continuing(robots)
    robots.robot_fault(1, "tb3_1: scan silent for 1.0 s")
    assert robots.stops == ["tb3_1: scan silent for 1.0 s"] and robots.fleet_stop.alone == []


def test_in_the_simulation_a_robot_whose_move_base_is_gone_leaves_with_continue():
    robots = FakeSimRobots()
    robots.settings.on_robot_fault = "continue"
    released = []
    robots.sim.tracks_answers = True
    robots.sim.release = released.append
    robots.bases[1].process_gone = lambda: True
    robots.bases[0].process_gone = lambda: False
    robots.dispatch(0, 0)
    robots.dispatch(1, 1)
    assert robots._lose_if_gone([0, 1])
    robots.sim.ends = {0: (100, GoalStatus.SUCCEEDED)}
    result = robots.advance(until=50.0)
    assert result.left == [(1, "tb3_1: move_base gone (its process does not answer)")] and released == [1]
    assert result.legs == [] and robots.legs.running() == [0]
    result = robots.advance(until=50.0)
    assert result.legs == [LegEnd(0, True)] and result.left == []
    # stop_fleet: nothing is let go; the caller aborts the episode as before.
    robots = FakeSimRobots()
    robots.bases[1].process_gone = lambda: True
    robots.dispatch(0, 0)
    assert not robots._lose_if_gone([1])
