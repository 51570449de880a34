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
