"""The ROS executor's step times do not depend on the sim time at which an episode started."""
from marl_mrta.ros.executor import _elapsed


def tick_stamp(tick: int, rate: int = 20) -> float:
    """A tick's sim time as rospy gives it: whole nanoseconds, then seconds as a double."""
    nsec = tick * 1_000_000_000 // rate
    return float(nsec // 1_000_000_000) + 1e-9 * float(nsec % 1_000_000_000)


def test_a_duration_is_the_same_from_every_start_tick():
    starts = range(0, 20_000, 20)   # aligned step starts, 1 s apart
    durations = {_elapsed(tick_stamp(t), tick_stamp(t + 934)) for t in starts}
    assert durations == {46.7}
    # The plain difference of the two doubles is not: the rounding of the absolute times shows.
    assert len({tick_stamp(t + 934) - tick_stamp(t) for t in starts}) > 1


# The guard against stock move_base's stale success (ros-planning/navigation#949), with test
# doubles for the executor's move_base links, simulator link and clock.
from types import SimpleNamespace  # noqa: E402

from actionlib_msgs.msg import GoalStatus  # noqa: E402

from marl_mrta.ros.executor import StaleSuccessGuard  # noqa: E402
from marl_mrta.ros.move_base_link import GoalResult  # noqa: E402


class FakeBase:
    def __init__(self, result=None):
        self.result, self.sent = result, []

    def send(self, x, y, yaw):
        self.sent.append((x, y, yaw))
        self.result = None


def fake_executor(results, poses, now=10.3):
    goal = SimpleNamespace(x=2.0, y=1.0, yaw=0.0)
    return SimpleNamespace(bases=[FakeBase(r) for r in results], sim=SimpleNamespace(poses=lambda: poses),
                           scenario=SimpleNamespace(tasks=[SimpleNamespace(id="A1", goal=goal)]),
                           clock=SimpleNamespace(now=lambda: now), namespaces=["tb3_0", "tb3_1"])


def test_a_quick_success_away_from_the_goal_sends_the_goal_once_more():
    reached = GoalResult(GoalStatus.SUCCEEDED, "Goal reached.", 10.1)
    executor = fake_executor([reached, reached], [(0.2, 1.0, 0.0), (1.98, 1.0, 0.0)])
    guard = StaleSuccessGuard(step_start=10.0)
    assert not guard.all_ended(executor, [0, 0], [0, 1])   # tb3_0's success is stale: goal again
    assert executor.bases[0].sent == [(2.0, 1.0, 0.0)] and executor.bases[1].sent == []
    executor.bases[0].result = GoalResult(GoalStatus.SUCCEEDED, "Goal reached.", 10.2)
    assert guard.all_ended(executor, [0, 0], [0, 1])       # once only: the second result counts
    assert executor.bases[0].sent == [(2.0, 1.0, 0.0)]


def test_a_success_after_driving_or_a_failure_is_taken_as_it_is():
    late = GoalResult(GoalStatus.SUCCEEDED, "Goal reached.", 14.0)
    aborted = GoalResult(GoalStatus.ABORTED, "Failed to find a valid plan.", 10.1)
    executor = fake_executor([late, aborted], [(0.2, 1.0, 0.0), (0.2, 1.0, 0.0)])
    assert StaleSuccessGuard(step_start=10.0).all_ended(executor, [0, 0], [0, 1])
    assert executor.bases[0].sent == [] and executor.bases[1].sent == []


# Event mode: each leg has its own goal timeout, so a wait for the next event ends at the earliest
# leg deadline when that comes before `until` (ros/event_legs.py, both ROS executors).
from marl_mrta.model.goal_timeout import GoalTimeout, LegTimeouts  # noqa: E402
from marl_mrta.ros.event_legs import LegBook  # noqa: E402


def test_a_wait_for_the_next_event_ends_at_the_earliest_leg_deadline():
    book = LegBook(3, LegTimeouts(GoalTimeout(60.0), 3))
    assert book.running() == [] and book.stop_time(120.0) == 120.0
    book.start(0, task=4, start=10.0, sent=1010.0, watch_tick=20200)
    book.start(2, task=1, start=35.5, sent=1035.5)
    assert book.running() == [0, 2]
    assert book.stop_time(120.0) == 70.0 and book.stop_time(50.0) == 50.0
    assert book.overdue(69.9) == [] and book.overdue(70.0) == [0]
    book.end(0)
    assert book.stop_time(120.0) == 95.5 and book.overdue(100.0) == [2]
    book.clear()
    assert book.running() == []


def test_with_auto_each_leg_gets_its_deadline_from_where_its_robot_stands():
    """Nodes: the two robots' starts, then the goals of tasks 0 and 1; a reached leg moves the
    robot's node to the task's goal, a failed one leaves it, a reset puts it back on its start."""
    nominal = [[0.0, 9.0, 10.0, 40.0],
               [9.0, 0.0, 20.0, 25.0],
               [10.0, 20.0, 0.0, 100.0],
               [40.0, 25.0, 100.0, 0.0]]
    book = LegBook(2, LegTimeouts(GoalTimeout(None, factor=2.0, margin=30.0), 2, nominal))
    assert book.start(0, task=0, start=0.0, sent=0.0).deadline == 2 * 10.0 + 30.0
    assert book.start(1, task=1, start=5.0, sent=5.0).deadline == 5.0 + 2 * 25.0 + 30.0
    assert book.stop_time(500.0) == 50.0
    book.end(0, reached=True)                   # tb3_0 now stands on task 0's goal
    assert book.start(0, task=1, start=12.0, sent=12.0).deadline == 12.0 + 2 * 100.0 + 30.0
    book.end(0)                                 # failed: it still stands on task 0's goal
    assert book.start(0, task=1, start=300.0, sent=300.0).deadline == 300.0 + 230.0
    book.reset()
    assert book.running() == [] and book.start(0, task=1, start=0.0, sent=0.0).deadline == 2 * 40.0 + 30.0
